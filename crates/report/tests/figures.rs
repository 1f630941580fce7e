//! Figures 2 and 7 render to PNG and SVG with the bundled font only.

use report::{Fig2Options, OverlapRow, ReportError, fig2, fig2_points};

/// A synthetic campaign shaped like the papers' (20 × 20 × 3 points, six algorithms): QRI and
/// QRF depend on the geometry, the vectorised kernels do not.
fn campaign(precision: &str) -> Vec<OverlapRow> {
    let mut rows = Vec::new();
    for r_star in [0.05, 0.5, 5.0] {
        for l in 1..=20 {
            for w in 1..=20 {
                let (l_star, w_star) = (f64::from(l), f64::from(w));
                for (algorithm, mean_ms) in [
                    ("arvo", 50.0 + r_star),
                    ("qri", 20.0 + 3.0 * r_star + 10.0 / (l_star * w_star).sqrt()),
                    ("qrf", 18.0 + 2.0 * r_star + 8.0 / (l_star + w_star)),
                    ("sse", 11.7),
                    ("ocsi", 11.5 + 0.01 * l_star),
                    ("ocsi_batch", 2.6 + 0.001 * w_star),
                ] {
                    rows.push(OverlapRow {
                        l_star,
                        w_star,
                        r_star,
                        precision: precision.into(),
                        algorithm: algorithm.into(),
                        mean_ms,
                        ns_per_check: mean_ms * 500.0,
                        acceptance: 0.4,
                        repeats: 3,
                        ..OverlapRow::default()
                    });
                }
            }
        }
    }
    rows
}

#[test]
fn png_and_svg_are_drawn() {
    let dir = tempfile::tempdir().expect("a temporary directory");
    let mut rows = campaign("f32");
    rows.extend(campaign("f64"));
    // A hole in the grid (a point not measured yet) must not break the figure.
    rows.retain(|r| !(r.l_star == 3.0 && r.w_star == 7.0 && r.algorithm == "qri"));

    let png = dir.path().join("fig2.png");
    fig2(&rows, "f32", &png, Fig2Options::default()).expect("the PNG renders");
    let image = image::open(&png).expect("the PNG decodes").to_rgb8();
    // 3 columns of 330 px + a 120 px colour bar; a 50 px title + 6 rows of 290 px.
    assert_eq!(image.dimensions(), (1110, 1790));
    let mut colours: Vec<[u8; 3]> = image.pixels().map(|p| p.0).collect();
    colours.sort_unstable();
    colours.dedup();
    assert!(
        colours.len() > 100,
        "a heat map has many colours, got {}",
        colours.len()
    );
    // Text was drawn: anti-aliased glyphs leave grey pixels in the title band.
    let title_greys = (0..1110)
        .flat_map(|x| (0..50).map(move |y| (x, y)))
        .filter(|&(x, y)| {
            let [r, g, b] = image.get_pixel(x, y).0;
            r == g && g == b && r < 200
        })
        .count();
    assert!(
        title_greys > 200,
        "the title's glyphs are in the PNG ({title_greys} dark pixels)"
    );

    let svg = dir.path().join("fig2.svg");
    fig2(&rows, "f64", &svg, Fig2Options::default()).expect("the SVG renders");
    let text = std::fs::read_to_string(&svg).expect("the SVG is text");
    assert!(text.len() > 100_000, "{} bytes", text.len());
    for label in [
        "L*",
        "W*",
        "R* = 0.05",
        "R* = 5",
        "QRI",
        "OCSI batch",
        "ms",
        "f64",
    ] {
        assert!(text.contains(label), "the SVG shows `{label}`");
    }
}

#[test]
fn unusable_requests_are_errors_and_write_nothing() {
    let dir = tempfile::tempdir().expect("a temporary directory");
    let rows = campaign("f32");
    let path = dir.path().join("fig2.pdf");
    assert!(matches!(
        fig2(&rows, "f32", &path, Fig2Options::default()),
        Err(ReportError::Extension { .. })
    ));
    let path = dir.path().join("fig2.png");
    let error = fig2(&rows, "f64", &path, Fig2Options::default()).expect_err("no f64 rows");
    assert_eq!(error.to_string(), "no f64 overlap results to plot");
    assert!(!path.exists());
}

/// With `show_ci`, every point with an interval gets a circle; a flagged point gets a cross;
/// the JSON points carry estimate and interval in the papers' order.
#[test]
fn intervals_and_flags_are_drawn_and_listed() {
    let dir = tempfile::tempdir().expect("a temporary directory");
    let mut rows = campaign("f32");
    rows.retain(|r| r.r_star == 5.0 && r.algorithm == "qri" && r.l_star <= 4.0 && r.w_star <= 4.0);
    for (k, r) in rows.iter_mut().enumerate() {
        r.ci95_lo_ns_per_check = Some(r.ns_per_check * 0.99);
        r.ci95_hi_ns_per_check = Some(r.ns_per_check * 1.01);
        r.disturbed = Some(k == 5);
    }
    let svg = dir.path().join("ci.svg");
    fig2(&rows, "f32", &svg, Fig2Options { show_ci: true }).expect("the SVG renders");
    let text = std::fs::read_to_string(&svg).expect("the SVG is text");
    assert_eq!(text.matches("<circle").count(), 16, "one circle per point");
    assert!(text.contains("circle: 95 % CI") && text.contains("×: disturbed"));
    // The cross is two red lines.
    assert!(
        text.matches("#DC1E1E").count() >= 2,
        "the flagged point's cross"
    );
    let plain = dir.path().join("plain.svg");
    fig2(&rows, "f32", &plain, Fig2Options::default()).expect("the SVG renders");
    assert_eq!(
        std::fs::read_to_string(&plain)
            .expect("text")
            .matches("<circle")
            .count(),
        0
    );

    let points = fig2_points(&rows, "f32").expect("points");
    assert_eq!(points.len(), 16);
    assert_eq!(
        (points[0].l_star, points[0].w_star, points[1].w_star),
        (1.0, 1.0, 2.0)
    );
    assert!(
        points
            .iter()
            .all(|p| p.ci95_lo_ns_per_check.is_some_and(|lo| lo < p.ns_per_check))
    );
    assert!(fig2_points(&rows, "f64").is_err());
}

mod fig7 {
    use report::{EdmdRow, ReportError, fig7};

    fn row(shape: &str, x0: f64, neighbours: &str, phi: f64, tau_c_us: f64) -> EdmdRow {
        EdmdRow {
            shape: shape.into(),
            x0,
            neighbours: neighbours.into(),
            delta_nnl: 0.08,
            n: 256,
            phi,
            tau_c_us,
        }
    }

    #[test]
    fn curves_of_tau_c_against_phi_are_drawn() {
        let dir = tempfile::tempdir().expect("a temporary directory");
        let mut rows = Vec::new();
        for (k, phi) in [0.3, 0.35, 0.4, 0.45, 0.5].into_iter().enumerate() {
            rows.push(row("sphere", 1.0, "ll", phi, 1.1));
            rows.push(row("ellipsoid", 2.0, "nnl", phi, 35.0 - 2.5 * k as f64));
            rows.push(row("ellipsoid", 2.0, "ll", phi, 47.0));
        }
        let png = dir.path().join("fig7.png");
        fig7(&rows, &png).expect("the PNG renders");
        let image = image::open(&png).expect("the PNG decodes").to_rgb8();
        assert_eq!(image.dimensions(), (900, 620));
        // Three curves in three colours (neither white, black nor grey).
        let mut colours: Vec<[u8; 3]> = image
            .pixels()
            .map(|p| p.0)
            .filter(|[r, g, b]| !(r == g && g == b))
            .collect();
        colours.sort_unstable();
        colours.dedup();
        assert!(colours.len() >= 3, "{} colours", colours.len());

        let svg = dir.path().join("fig7.svg");
        fig7(&rows, &svg).expect("the SVG renders");
        let text = std::fs::read_to_string(&svg).expect("the SVG is text");
        for label in [
            "sphere, LL, N = 256",
            "ellipsoid X0 = 2, NNL (Δ = 0.08), N = 256",
            "ellipsoid X0 = 2, LL, N = 256",
            "τ_c (µs)",
        ] {
            assert!(text.contains(label), "the SVG lacks {label:?}");
        }
    }

    #[test]
    fn no_edmd_rows_is_an_error_and_writes_nothing() {
        let dir = tempfile::tempdir().expect("a temporary directory");
        let png = dir.path().join("fig7.png");
        assert!(matches!(fig7(&[], &png), Err(ReportError::NoEdmdRows)));
        assert!(!png.exists());
    }
}
