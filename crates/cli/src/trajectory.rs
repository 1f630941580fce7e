//! `sweep edmd --trajectory F.gsd`: a run's frames in GSD with HOOMD's schema (1.4), which
//! OVITO and the `gsd` Python package read.
//!
//! Per frame: `configuration/step` (collisions since the end of the initial state),
//! `configuration/box` ([L, L, L, 0, 0, 0]), `particles/N`, `particles/position` (wrapped into
//! HOOMD's box, which is centred on the origin: ours shifted by −L/2), `particles/image` (so that
//! position + image·L + L/2 is our unwrapped position), `particles/orientation` (the quaternion
//! (w, x, y, z) that turns the body frame into the lab frame: the body's a axis is the rotated
//! x axis), `particles/velocity`, and the angular velocity (lab frame) in
//! `log/particles/angular_velocity` (HOOMD's `particles/angmom` is a quaternion momentum of
//! its own integrator; a plain vector is more use here), and the simulated time in
//! `log/edmd/time` (f64). In frame 0 only (the schema's readers take later frames' from it):
//! `particles/typeid` (0 for all), `particles/types` and `particles/type_shapes` (JSON): a
//! `Sphere` with its diameter, an `Ellipsoid` with semi-axes a, b, c, and a superquadric as a
//! `ConvexPolyhedron` through 162 points of its surface (the hull of points on a convex
//! surface: inscribed, exact at the points). Float chunks are 32-bit, as the schema has them.

use std::fs::File;
use std::io::BufWriter;
use std::path::Path;

use anyhow::Context;
use edmd::rigid::Body;
use edmd::{Frame, Scene, ShapeKind};
use gsd::Writer;

const NAMES: [&str; 12] = [
    "configuration/step",
    "configuration/box",
    "particles/N",
    "particles/types",
    "particles/typeid",
    "particles/type_shapes",
    "particles/position",
    "particles/orientation",
    "particles/velocity",
    "particles/image",
    "log/particles/angular_velocity",
    "log/edmd/time",
];

pub struct Trajectory {
    w: Writer<BufWriter<File>>,
    /// The `type_shapes` entry of the scene's one type.
    shape: String,
    type_name: &'static str,
    // Chunks of one frame, reused.
    pos: Vec<f32>,
    img: Vec<i32>,
    quat: Vec<f32>,
    vel: Vec<f32>,
    ang: Vec<f32>,
}

impl Trajectory {
    pub fn create(path: &Path, scene: &Scene) -> anyhow::Result<Self> {
        let file =
            File::create(path).with_context(|| format!("cannot create {}", path.display()))?;
        let w = Writer::create(BufWriter::new(file), "sweep", "hoomd", (1, 4), &NAMES)
            .with_context(|| format!("cannot write {}", path.display()))?;
        let [a, b, c] = scene.semi_axes();
        let (type_name, shape) = match scene.shape {
            ShapeKind::Sphere => (
                "sphere",
                format!(r#"{{"type":"Sphere","diameter":{}}}"#, 2.0 * a),
            ),
            ShapeKind::Ellipsoid => (
                "ellipsoid",
                format!(r#"{{"type":"Ellipsoid","a":{a},"b":{b},"c":{c}}}"#),
            ),
            ShapeKind::Superquadric => {
                let e = scene.exponents.unwrap_or([2.0; 3]);
                let vertices: Vec<String> = superquadric_points([a, b, c], e)
                    .iter()
                    .map(|p| format!("[{},{},{}]", p[0], p[1], p[2]))
                    .collect();
                (
                    "superquadric",
                    format!(
                        r#"{{"type":"ConvexPolyhedron","rounding_radius":0,"vertices":[{}]}}"#,
                        vertices.join(",")
                    ),
                )
            }
        };
        Ok(Trajectory {
            w,
            shape,
            type_name,
            pos: Vec::new(),
            img: Vec::new(),
            quat: Vec::new(),
            vel: Vec::new(),
            ang: Vec::new(),
        })
    }

    /// Appends one frame.
    pub fn write(&mut self, f: &Frame) -> Result<(), gsd::GsdError> {
        let n = f.bodies.len();
        let l = f.box_length;
        let lf = l as f32;
        self.pos.clear();
        self.img.clear();
        self.quat.clear();
        self.vel.clear();
        self.ang.clear();
        for b in f.bodies {
            for k in 0..3 {
                let image = (b.r[k] / l).floor();
                self.pos.push((b.r[k] - image * l - 0.5 * l) as f32);
                self.img.push(image as i32);
                self.vel.push(b.v[k] as f32);
                self.ang.push(b.w[k] as f32);
            }
            self.quat.extend(quaternion(b).map(|x| x as f32));
        }
        let w = &mut self.w;
        let nu = n as u64;
        w.write_chunk("configuration/step", 1, 1, &[f.step])?;
        w.write_chunk("configuration/box", 6, 1, &[lf, lf, lf, 0.0, 0.0, 0.0])?;
        w.write_chunk("particles/N", 1, 1, &[n as u32])?;
        if w.frames() == 0 {
            let (types, m) = text_rows(&[self.type_name]);
            w.write_chunk("particles/types", 1, m, &types)?;
            w.write_chunk("particles/typeid", nu, 1, &vec![0u32; n])?;
            let (shapes, m) = text_rows(&[&self.shape]);
            w.write_chunk("particles/type_shapes", 1, m, &shapes)?;
        }
        w.write_chunk("particles/position", nu, 3, &self.pos)?;
        w.write_chunk("particles/orientation", nu, 4, &self.quat)?;
        w.write_chunk("particles/velocity", nu, 3, &self.vel)?;
        w.write_chunk("particles/image", nu, 3, &self.img)?;
        w.write_chunk("log/particles/angular_velocity", nu, 3, &self.ang)?;
        w.write_chunk("log/edmd/time", 1, 1, &[f.time])?;
        w.end_frame()
    }

    pub fn frames(&self) -> u64 {
        self.w.frames()
    }
}

/// Strings as the schema stores them: one row each, 0-padded to the longest plus one.
fn text_rows(texts: &[&str]) -> (Vec<i8>, u32) {
    let m = texts.iter().map(|t| t.len()).max().unwrap_or(0) + 1;
    let mut rows = Vec::with_capacity(m * texts.len());
    for t in texts {
        rows.extend(t.bytes().map(|c| c as i8));
        rows.resize(rows.len() + m - t.len(), 0);
    }
    (rows, m as u32)
}

/// The unit quaternion (w, x, y, z) of the rotation Q = Rᵀ that takes body-frame vectors to
/// the lab frame (the rows of R are the body axes), by Shepperd's method (the largest of the
/// four squares first, for accuracy).
pub fn quaternion(b: &Body) -> [f64; 4] {
    let q = |i: usize, j: usize| b.rot[(j, i)];
    let trace = q(0, 0) + q(1, 1) + q(2, 2);
    let v = if trace > 0.0 {
        let s = 2.0 * (trace + 1.0).sqrt();
        [
            0.25 * s,
            (q(2, 1) - q(1, 2)) / s,
            (q(0, 2) - q(2, 0)) / s,
            (q(1, 0) - q(0, 1)) / s,
        ]
    } else if q(0, 0) > q(1, 1) && q(0, 0) > q(2, 2) {
        let s = 2.0 * (1.0 + q(0, 0) - q(1, 1) - q(2, 2)).sqrt();
        [
            (q(2, 1) - q(1, 2)) / s,
            0.25 * s,
            (q(0, 1) + q(1, 0)) / s,
            (q(0, 2) + q(2, 0)) / s,
        ]
    } else if q(1, 1) > q(2, 2) {
        let s = 2.0 * (1.0 + q(1, 1) - q(0, 0) - q(2, 2)).sqrt();
        [
            (q(0, 2) - q(2, 0)) / s,
            (q(0, 1) + q(1, 0)) / s,
            0.25 * s,
            (q(1, 2) + q(2, 1)) / s,
        ]
    } else {
        let s = 2.0 * (1.0 + q(2, 2) - q(0, 0) - q(1, 1)).sqrt();
        [
            (q(1, 0) - q(0, 1)) / s,
            (q(0, 2) + q(2, 0)) / s,
            (q(1, 2) + q(2, 1)) / s,
            0.25 * s,
        ]
    };
    let norm = v.iter().map(|x| x * x).sum::<f64>().sqrt();
    v.map(|x| x / norm)
}

/// Points of the superquadric Σ |x_k / s_k|^e_k = 1 (Eq. 77) along 162 directions (a
/// geodesic sphere: the icosahedron's 12 vertices and its edges and faces subdivided twice),
/// each found by bisection on the ray.
fn superquadric_points(s: [f64; 3], e: [f64; 3]) -> Vec<[f64; 3]> {
    let f = |p: [f64; 3]| (0..3).map(|k| (p[k] / s[k]).abs().powf(e[k])).sum::<f64>();
    geodesic_directions()
        .into_iter()
        .map(|d| {
            let (mut lo, mut hi) = (0.0, 2.0 * s.iter().cloned().fold(0.0, f64::max));
            for _ in 0..60 {
                let mid = 0.5 * (lo + hi);
                if f(d.map(|x| x * mid)) < 1.0 {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            d.map(|x| x * lo)
        })
        .collect()
}

/// 162 unit vectors: an icosahedron subdivided twice, projected on the sphere.
fn geodesic_directions() -> Vec<[f64; 3]> {
    let g = (1.0 + 5f64.sqrt()) / 2.0;
    let mut v: Vec<[f64; 3]> = vec![
        [-1.0, g, 0.0],
        [1.0, g, 0.0],
        [-1.0, -g, 0.0],
        [1.0, -g, 0.0],
        [0.0, -1.0, g],
        [0.0, 1.0, g],
        [0.0, -1.0, -g],
        [0.0, 1.0, -g],
        [g, 0.0, -1.0],
        [g, 0.0, 1.0],
        [-g, 0.0, -1.0],
        [-g, 0.0, 1.0],
    ];
    let mut faces: Vec<[usize; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    let unit = |p: [f64; 3]| {
        let n = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
        p.map(|x| x / n)
    };
    v.iter_mut().for_each(|p| *p = unit(*p));
    for _ in 0..2 {
        let mut midpoints = std::collections::HashMap::new();
        let mut mid = |a: usize, b: usize, v: &mut Vec<[f64; 3]>| {
            *midpoints.entry((a.min(b), a.max(b))).or_insert_with(|| {
                v.push(unit([0, 1, 2].map(|k| v[a][k] + v[b][k])));
                v.len() - 1
            })
        };
        faces = faces
            .iter()
            .flat_map(|&[a, b, c]| {
                let (ab, bc, ca) = (mid(a, b, &mut v), mid(b, c, &mut v), mid(c, a, &mut v));
                [[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]
            })
            .collect();
    }
    v
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The quaternion turns the body axes e_x, e_y, e_z into the rows of R, for rotations
    /// that reach every branch of Shepperd's method.
    #[test]
    fn quaternion_rotates_body_axes_onto_the_rows() {
        let rotate = |q: [f64; 4], v: [f64; 3]| {
            let [w, x, y, z] = q;
            let u = [x, y, z];
            let cross = |a: [f64; 3], b: [f64; 3]| {
                [
                    a[1] * b[2] - a[2] * b[1],
                    a[2] * b[0] - a[0] * b[2],
                    a[0] * b[1] - a[1] * b[0],
                ]
            };
            let t = cross(u, v).map(|c| 2.0 * c);
            let ut = cross(u, t);
            [0, 1, 2].map(|k| v[k] + w * t[k] + ut[k])
        };
        for (axis, angle) in [
            ([0.0, 0.0, 1.0], 0.3),
            ([1.0, 0.0, 0.0], 3.0),
            ([0.0, 1.0, 0.0], 3.0),
            ([0.0, 0.0, 1.0], 3.0),
            ([1.0, 2.0, -0.5], 2.2),
        ] {
            let axis = edmd::geometry::V3::from(axis).normalize();
            let rot_lab = nalgebra_rotation(&axis, angle);
            let body = Body {
                r: Default::default(),
                v: Default::default(),
                t: 0.0,
                rot: rot_lab.transpose(),
                w: Default::default(),
            };
            let q = quaternion(&body);
            for k in 0..3 {
                let mut e = [0.0; 3];
                e[k] = 1.0;
                let got = rotate(q, e);
                for (j, g) in got.iter().enumerate() {
                    assert!((g - body.rot[(k, j)]).abs() < 1e-12, "{axis:?} {angle}");
                }
            }
        }
    }

    /// Rodrigues' rotation matrix about a unit axis.
    fn nalgebra_rotation(u: &edmd::geometry::V3, angle: f64) -> edmd::geometry::M3 {
        let k = u.cross_matrix();
        edmd::geometry::M3::identity() + k * angle.sin() + k * k * (1.0 - angle.cos())
    }

    #[test]
    fn superquadric_points_lie_on_the_surface() {
        let (s, e) = ([0.8, 0.4, 0.4], [2.0, 2.0, 6.0]);
        let points = superquadric_points(s, e);
        assert_eq!(points.len(), 162);
        for p in points {
            let f: f64 = (0..3).map(|k| (p[k] / s[k]).abs().powf(e[k])).sum();
            assert!((f - 1.0).abs() < 1e-9, "{f}");
        }
    }
}
