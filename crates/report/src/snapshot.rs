//! `sweep report snapshot`: a picture of a configuration, to look at rather than read (a nematic,
//! a jammed packing): the bodies whose centres lie in a slab across the periodic box, seen
//! orthographically along z, each drawn as the exact outline of its ellipsoid (the Schur
//! complement below) and coloured by its long axis: the hue is the axis' direction in the
//! picture's plane (mod 180°, so that a nematic's domains show as colours), the saturation how
//! much of the axis lies in the plane (an axis along the view is white). Nearer bodies are
//! drawn last. Spheres are drawn grey. Superquadrics are drawn as the ellipsoid of their
//! semi-axes (their outline is not an ellipse).

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::ReportError;
use crate::render::{DrawResult, Drawing, FONT, render};

/// One body: its centre (any periodic image), its body axes in the lab frame (rows, unit) and
/// its semi-axes along them, the first the long one for a prolate body.
#[derive(Clone, Copy, Debug)]
pub struct SnapshotBody {
    pub centre: [f64; 3],
    pub axes: [[f64; 3]; 3],
    pub semi_axes: [f64; 3],
}

/// What to draw: a periodic cube of side `box_length`, the bodies whose (wrapped) centre's z
/// lies within `slab` of the box's middle plane.
pub struct Snapshot {
    pub box_length: f64,
    pub bodies: Vec<SnapshotBody>,
    /// Half the slab's thickness.
    pub slab: f64,
    /// Drawn above the picture.
    pub title: String,
    /// Whether orientation means anything (not for spheres).
    pub oriented: bool,
}

const SIDE: u32 = 900;
const TOP: u32 = 40;
/// Points on each outline.
const OUTLINE: usize = 40;

/// An outline to draw: its points in the box's x, y, its depth, its colour.
struct Outline {
    points: Vec<(f64, f64)>,
    depth: f64,
    colour: RGBColor,
}

impl Snapshot {
    /// The bodies in the slab, as outlines sorted far to near.
    fn outlines(&self) -> Vec<Outline> {
        let l = self.box_length;
        let mut out: Vec<Outline> = self
            .bodies
            .iter()
            .filter_map(|b| {
                let c = b.centre.map(|x| x.rem_euclid(l));
                let depth = c[2] - 0.5 * l;
                if depth.abs() > self.slab {
                    return None;
                }
                let (p, q, r) = projected_ellipse(b);
                // The ellipse's axes from the eigen-decomposition of [[p, q], [q, r]].
                let (l1, l2, angle) = eigen_2x2(p, q, r);
                let (sa, ca) = angle.sin_cos();
                let points = (0..OUTLINE)
                    .map(|k| {
                        let t = std::f64::consts::TAU * k as f64 / OUTLINE as f64;
                        let (s, cth) = t.sin_cos();
                        let (u, v) = (cth / l1.sqrt(), s / l2.sqrt());
                        (c[0] + u * ca - v * sa, c[1] + u * sa + v * ca)
                    })
                    .collect();
                Some(Outline {
                    points,
                    depth,
                    colour: if self.oriented {
                        orientation_colour(&b.axes[long_axis(b)])
                    } else {
                        RGBColor(150, 160, 175)
                    },
                })
            })
            .collect();
        out.sort_by(|a, b| a.depth.total_cmp(&b.depth));
        out
    }

    /// How many bodies the slab holds.
    pub fn shown(&self) -> usize {
        self.outlines().len()
    }
}

/// The index of the longest semi-axis.
fn long_axis(b: &SnapshotBody) -> usize {
    (0..3)
        .max_by(|&i, &j| b.semi_axes[i].total_cmp(&b.semi_axes[j]))
        .unwrap_or(0)
}

/// The outline of the ellipsoid xᵀ M x = 1 (M = Σ_k u_k u_kᵀ / s_k², u_k the body axes) seen
/// along z: the ellipse pᵀ (M_pp − M_pz M_zz⁻¹ M_zp) p = 1 on (x, y), as (M'_xx, M'_xy, M'_yy).
fn projected_ellipse(b: &SnapshotBody) -> (f64, f64, f64) {
    let m: [[f64; 3]; 3] = std::array::from_fn(|i| {
        std::array::from_fn(|j| {
            (0..3)
                .map(|k| b.axes[k][i] * b.axes[k][j] / (b.semi_axes[k] * b.semi_axes[k]))
                .sum()
        })
    });
    let zz = m[2][2];
    (
        m[0][0] - m[0][2] * m[2][0] / zz,
        m[0][1] - m[0][2] * m[2][1] / zz,
        m[1][1] - m[1][2] * m[2][1] / zz,
    )
}

/// Eigenvalues of the symmetric [[p, q], [q, r]] and the angle of the first one's eigenvector.
fn eigen_2x2(p: f64, q: f64, r: f64) -> (f64, f64, f64) {
    let angle = 0.5 * (2.0 * q).atan2(p - r);
    let (s, c) = angle.sin_cos();
    let l1 = p * c * c + 2.0 * q * s * c + r * s * s;
    let l2 = p * s * s - 2.0 * q * s * c + r * c * c;
    (l1, l2, angle)
}

/// Hue from the axis' direction in the (x, y) plane, mod 180°; saturation from how much of it
/// lies in the plane.
fn orientation_colour(u: &[f64; 3]) -> RGBColor {
    let in_plane = (u[0] * u[0] + u[1] * u[1]).sqrt().min(1.0);
    let hue = (u[1].atan2(u[0]).rem_euclid(std::f64::consts::PI)) / std::f64::consts::PI;
    let (r, g, b) = hsv(hue, 0.85 * in_plane, 0.95);
    RGBColor(r, g, b)
}

fn hsv(h: f64, s: f64, v: f64) -> (u8, u8, u8) {
    let i = (h * 6.0).floor();
    let f = h * 6.0 - i;
    let (p, q, t) = (v * (1.0 - s), v * (1.0 - f * s), v * (1.0 - (1.0 - f) * s));
    let (r, g, b) = match (i as i64).rem_euclid(6) {
        0 => (v, t, p),
        1 => (q, v, p),
        2 => (p, v, t),
        3 => (p, q, v),
        4 => (t, p, v),
        _ => (v, p, q),
    };
    let byte = |x: f64| (x * 255.0).round().clamp(0.0, 255.0) as u8;
    (byte(r), byte(g), byte(b))
}

impl Drawing for Snapshot {
    fn size(&self) -> (u32, u32) {
        (SIDE, SIDE + TOP)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult
    where
        DB::ErrorType: 'static,
    {
        root.fill(&WHITE)?;
        let (title, picture) = root.split_vertically(TOP);
        title.draw(&Text::new(
            self.title.clone(),
            (10, 10),
            (FONT, 18).into_font().color(&BLACK),
        ))?;
        let l = self.box_length;
        let scale = f64::from(SIDE) / l;
        let px = |(x, y): (f64, f64)| ((x * scale) as i32, (f64::from(SIDE) - y * scale) as i32);
        for o in self.outlines() {
            let points: Vec<(i32, i32)> = o.points.iter().map(|&p| px(p)).collect();
            picture.draw(&Polygon::new(points.clone(), o.colour.filled()))?;
            let mut closed = points;
            closed.push(closed[0]);
            picture.draw(&PathElement::new(closed, BLACK.mix(0.6).stroke_width(1)))?;
        }
        picture.draw(&Rectangle::new(
            [(0, 0), (SIDE as i32 - 1, SIDE as i32 - 1)],
            BLACK.stroke_width(1),
        ))?;
        Ok(())
    }
}

/// Draws `snapshot` into `path` (.png or .svg).
pub fn snapshot(snapshot: &Snapshot, path: &Path) -> Result<(), ReportError> {
    render(snapshot, path)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A prolate ellipsoid lying along x projects to its own a × b ellipse; standing along z,
    /// to the b × c circle.
    #[test]
    fn outlines_are_the_projected_ellipses() {
        let lying = SnapshotBody {
            centre: [0.0; 3],
            axes: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            semi_axes: [0.8, 0.4, 0.4],
        };
        let (p, q, r) = projected_ellipse(&lying);
        assert!(
            (p - 1.0 / 0.64).abs() < 1e-12 && q.abs() < 1e-12 && (r - 1.0 / 0.16).abs() < 1e-12
        );
        let standing = SnapshotBody {
            axes: [[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]],
            ..lying
        };
        let (p, q, r) = projected_ellipse(&standing);
        assert!(
            (p - 1.0 / 0.16).abs() < 1e-12 && q.abs() < 1e-12 && (r - 1.0 / 0.16).abs() < 1e-12
        );
        // Tilted by 45° about z: the outline's extent along x is a·cos² + b·sin² in M'.
        let s = std::f64::consts::FRAC_1_SQRT_2;
        let tilted = SnapshotBody {
            axes: [[s, s, 0.0], [-s, s, 0.0], [0.0, 0.0, 1.0]],
            ..lying
        };
        let (p, q, r) = projected_ellipse(&tilted);
        let (l1, l2, _) = eigen_2x2(p, q, r);
        let mut radii = [1.0 / l1.sqrt(), 1.0 / l2.sqrt()];
        radii.sort_by(f64::total_cmp);
        assert!((radii[0] - 0.4).abs() < 1e-12 && (radii[1] - 0.8).abs() < 1e-12);
    }

    #[test]
    fn colours_follow_the_axis_mod_half_a_turn() {
        assert_eq!(
            orientation_colour(&[1.0, 0.0, 0.0]),
            orientation_colour(&[-1.0, 0.0, 0.0])
        );
        assert_ne!(
            orientation_colour(&[1.0, 0.0, 0.0]),
            orientation_colour(&[0.0, 1.0, 0.0])
        );
        // Along the view: white.
        assert_eq!(
            orientation_colour(&[0.0, 0.0, 1.0]),
            RGBColor(242, 242, 242)
        );
    }
}
