//! Figures 2 and 7 render to PNG and SVG with the bundled font only.

use report::{Fig2Options, OverlapPoint, ReportError, fig2, fig2_points};

/// A synthetic campaign shaped like the papers' (20 × 20 × 3 points, six algorithms): QRI and
/// QRF depend on the geometry, the vectorised kernels do not.
fn campaign(precision: &str) -> Vec<OverlapPoint> {
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
                    rows.push(OverlapPoint {
                        l_star,
                        w_star,
                        r_star,
                        precision: precision.into(),
                        algorithm: algorithm.into(),
                        mean_ms,
                        ns_per_check: mean_ms * 500.0,
                        acceptance: 0.4,
                        repeats: 3,
                        ..OverlapPoint::default()
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
            ..Default::default()
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
            "τ_c (µs, wall time)",
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

/// Figures 8–11 and the accuracy report over a synthetic campaign shaped like
/// `deploy/plans/edmd-figures.toml`, with laws whose answers are known.
mod edmd_figures {
    use report::{
        EdmdRow, LengthUnit, ReportError, VerdictRow, accuracy, accuracy_markdown, accuracy_plot,
        accuracy_report, fig8, fig9, fig10, fig11,
    };

    const DELTAS: [f64; 8] = [0.01, 0.02, 0.035, 0.06, 0.1, 0.16, 0.25, 0.4];

    fn run(x0: f64, phi: f64, neighbours: &str) -> EdmdRow {
        EdmdRow {
            shape: "ellipsoid".into(),
            x0,
            neighbours: neighbours.into(),
            delta_nnl: 0.06,
            n: 256,
            phi,
            eps_d: 1e-5,
            eps_nnl: 5e-3,
            nr_tol: 1e-12,
            nr_max_iter: 50,
            nr_relax: 0.5,
            sd_max_iter: 200,
            sd_tol: 1e-3,
            brent_tol: 1e-12,
            seed: 1,
            collisions: 20_000,
            pressure_z: 10.0,
            pressure_z_err: Some(0.1),
            ..Default::default()
        }
    }

    /// LL grows as X0² (prolate) and 1/X0 (oblate); NNL is X0-independent and has its minimum
    /// over Δ_NNL at Δ* = 0.05/φ σ (an exact parabola in log Δ); τ_c rises 10 % per decade of ε_d
    /// and ε_d = 1e-2 finds overlaps.
    fn campaign() -> Vec<EdmdRow> {
        let mut rows = Vec::new();
        for phi in [0.3, 0.4, 0.5] {
            for x0 in [0.25, 0.5, 1.0, 2.0, 4.0] {
                let elongation = if x0 > 1.0 { x0 * x0 } else { 1.0 / x0 };
                rows.push(EdmdRow {
                    tau_c_us: 20.0 * phi * elongation,
                    ..run(x0, phi, "ll")
                });
                rows.push(EdmdRow {
                    tau_c_us: 30.0,
                    ..run(x0, phi, "nnl")
                });
            }
        }
        for x0 in [0.5, 2.0] {
            for phi in [0.3, 0.45, 0.57] {
                // Δ = 0.06 with ε_d = 1e-5 is the baseline point, run once (a plan keeps one
                // job per distinct point): both laws pass through its τ_c = 30.
                let star = 0.05 / phi;
                let law = |delta: f64| 4.0 * (delta / star).ln().powi(2);
                if phi != 0.3 {
                    rows.push(EdmdRow {
                        tau_c_us: 30.0,
                        ..run(x0, phi, "nnl")
                    });
                }
                for delta in DELTAS.into_iter().filter(|&d| d != 0.06) {
                    // Eq. 73 in time: list updates take 1/(1 + 10 Δ/σ) of τ_c.
                    let tau = 30.0 + law(delta) - law(0.06);
                    let share = 1.0 / (1.0 + 10.0 * delta);
                    rows.push(EdmdRow {
                        delta_nnl: delta,
                        tau_c_us: tau,
                        tau_update_us: Some(share * tau),
                        tau_predict_us: Some((1.0 - share) * tau),
                        ..run(x0, phi, "nnl")
                    });
                }
                for eps_d in [1e-7_f64, 1e-6, 1e-4, 1e-3, 1e-2] {
                    let decades = eps_d.log10() + 5.0;
                    rows.push(EdmdRow {
                        eps_d,
                        tau_c_us: 30.0 * (1.0 + 0.1 * decades),
                        overlaps: u64::from(eps_d > 5e-3),
                        ..run(x0, phi, "nnl")
                    });
                }
            }
        }
        rows
    }

    fn svg_text(path: &std::path::Path) -> String {
        std::fs::read_to_string(path).expect("the SVG is text")
    }

    #[test]
    fn every_figure_renders_from_a_fixture_campaign() {
        let dir = tempfile::tempdir().expect("a temporary directory");
        let rows = campaign();
        for (name, labels) in [
            (
                "fig8",
                vec!["τ_c^LL / τ_c^NNL", "X0 = a/b", "φ = 0.3, LL", "guide ∝ X0²"],
            ),
            (
                "fig9",
                vec![
                    "ε_d (unit: smallest semi-axis",
                    "overlaps found",
                    "X0 = 0.5, NNL",
                ],
            ),
            (
                "fig10",
                vec!["Δ_NNL (unit: smallest semi-axis", "Δ* = ", "φ = 0.45, NNL"],
            ),
            ("fig11", vec!["Δ*_NNL against φ", "Δ*_NNL against X0"]),
        ] {
            for extension in ["png", "svg"] {
                let path = dir.path().join(format!("{name}.{extension}"));
                let unit = LengthUnit::SemiAxis;
                let drawn = match name {
                    "fig8" => fig8(&rows, Some(&path)).map(|_| ()),
                    "fig9" => fig9(&rows, unit, Some(&path)).map(|_| ()),
                    "fig10" => fig10(&rows, unit, Some(&path)).map(|_| ()),
                    _ => fig11(&rows, &[], unit, Some(&path)).map(|_| ()),
                };
                drawn.unwrap_or_else(|e| panic!("{name}.{extension}: {e}"));
                let bytes = std::fs::metadata(&path).expect("written").len();
                assert!(bytes > 10_000, "{name}.{extension}: {bytes} bytes");
                if extension == "png" {
                    image::open(&path).expect("the PNG decodes");
                } else {
                    let text = svg_text(&path);
                    for label in &labels {
                        assert!(text.contains(label), "{name}.svg lacks {label:?}");
                    }
                }
            }
        }
        let study = accuracy(&rows).expect("an ε_d study");
        let svg = dir.path().join("accuracy.svg");
        accuracy_plot(&study, &svg).expect("the accuracy plot renders");
        assert!(svg_text(&svg).contains("Pareto front"));

        // With the overlap family: its two panels come first, both families in one figure.
        let study = accuracy_report(&rows, &[], &verdicts()).expect("both families");
        assert!(study.missing.is_empty(), "{:?}", study.missing);
        for extension in ["png", "svg"] {
            let path = dir.path().join(format!("accuracy-both.{extension}"));
            accuracy_plot(&study, &path).expect("renders");
            if extension == "svg" {
                let text = svg_text(&path);
                for label in [
                    "cost against wrong verdicts near contact",
                    "by distance from contact",
                    "EDMD: eps_d",
                    "OCSI batch f32",
                ] {
                    assert!(text.contains(label), "accuracy.svg lacks {label:?}");
                }
            } else {
                image::open(&path).expect("the PNG decodes");
            }
        }
        let text = accuracy_markdown(&study);
        assert!(
            text.contains("## Overlap kernels: f32 against f64") && text.contains("### eps_d"),
            "{text}"
        );
    }

    /// Two algorithms in f32 and f64 at two points; f32 is wrong near contact, OCSI batch f32
    /// once in the bulk too.
    fn verdicts() -> Vec<VerdictRow> {
        let mut rows = Vec::new();
        for r_star in [0.05, 5.0] {
            for (algorithm, ns) in [("ocsi", 10.0), ("ocsi_batch", 2.0)] {
                for (precision, scale, wrong) in [
                    ("f32", 1.0, [0, 0, 0, 5, 40, 50]),
                    ("f64", 1.6, [0, 0, 0, 0, 0, 3]),
                ] {
                    rows.push(VerdictRow {
                        l_star: 2.0,
                        w_star: 3.0,
                        r_star,
                        precision: precision.into(),
                        algorithm: algorithm.into(),
                        ns_per_check: ns * scale,
                        bulk: 10_000,
                        shell: 600,
                        bulk_wrong: u64::from(algorithm == "ocsi_batch" && precision == "f32"),
                        shell_wrong: wrong.iter().sum(),
                        shell_max_gap: 1e-3,
                        shell_by_decade: vec![100; 6],
                        shell_wrong_by_decade: wrong.to_vec(),
                    });
                }
            }
        }
        rows
    }

    #[test]
    fn the_overlap_family_alone_recommends_and_the_edmd_one_is_named_missing() {
        let study = accuracy_report(&[], &[], &verdicts()).expect("the overlap family");
        assert!(study.knobs.is_empty());
        assert!(
            study.missing[0].contains("EDMD runs of one state point"),
            "{:?}",
            study.missing
        );
        let overlap = study.overlap.as_ref().expect("overlap settings");
        assert_eq!(overlap.settings.len(), 4);
        let recommended = overlap.recommended.as_ref().expect("a safe setting");
        // OCSI batch f32 is the cheapest but was wrong once in the bulk: its f64 is next.
        assert_eq!(
            (
                recommended.algorithm.as_str(),
                recommended.precision.as_str()
            ),
            ("ocsi_batch", "f64")
        );
        let gap = recommended
            .trusted_above_gap
            .expect("f64 was wrong in the last decade");
        assert!((gap / 1e-8 - 1.0).abs() < 1e-9, "{gap}");
        match accuracy_report(&[], &[], &[]) {
            Err(ReportError::MissingPoints { figure, missing }) => {
                assert_eq!(figure, "accuracy");
                assert_eq!(missing.len(), 2, "{missing:?}");
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn the_figures_data_follow_the_laws_they_were_given() {
        let rows = campaign();
        let f8 = fig8(&rows, None).expect("fig8");
        assert_eq!(f8.curves.len(), 6, "LL and NNL at three φ");
        assert!(f8.missing.is_empty(), "{:?}", f8.missing);
        let ratio = &f8.ratios[0];
        let at = |x0: f64| ratio.points.iter().find(|p| p.x0 == x0).unwrap().ratio;
        assert!((at(4.0) / at(2.0) - 4.0).abs() < 1e-12, "X0² when prolate");
        assert!((at(0.25) / at(0.5) - 2.0).abs() < 1e-12, "1/X0 when oblate");

        let f9 = fig9(&rows, LengthUnit::Sigma, None).expect("fig9");
        assert_eq!(f9.curves.len(), 6);
        assert!(f9.curves.iter().all(|c| c.overlapping == Some(vec![1e-2])));

        // Δ* = 0.05/φ σ, exactly, where the grid brackets it; in the paper's unit it is that over
        // the smallest semi-axis.
        let f11 = fig11(&rows, &[], LengthUnit::SemiAxis, None).expect("fig11");
        for m in &f11.minima {
            assert!(m.bracketed, "{m:?}");
            assert!((m.delta_star_sigma - 0.05 / m.phi).abs() < 1e-9, "{m:?}");
            let semi_axis = if m.x0 > 1.0 {
                0.5 / m.x0.cbrt()
            } else {
                0.5 * m.x0.powf(2.0 / 3.0)
            };
            assert!(
                (m.delta_star * semi_axis - m.delta_star_sigma).abs() < 1e-9,
                "{m:?}"
            );
        }
        // Fig. 11's right panel needs φ = 0.40 and 0.55 at two X0: the fixture has neither.
        assert!(
            f11.missing.iter().any(|m| m.contains("φ = 0.4")),
            "{:?}",
            f11.missing
        );
        let f10 = fig10(&rows, LengthUnit::Sigma, None).expect("fig10");
        assert!(f10.missing.is_empty(), "{:?}", f10.missing);
        for curve in &f10.curves {
            // Every Δ but the baseline's 0.06 (run without the split) has it.
            let split = &curve.optimum.as_ref().expect("Fig. 10's part").split;
            assert_eq!(split.len(), DELTAS.len() - 1, "{curve:?}");
            for s in split {
                assert!(
                    (s.update_share - 1.0 / (1.0 + 10.0 * s.x)).abs() < 1e-12,
                    "{s:?}"
                );
            }
        }
        for m in &f11.minima {
            let share = m.update_share.expect("a split near Δ*");
            let nearest = DELTAS
                .into_iter()
                .filter(|&d| d != 0.06)
                .min_by(|a, b| {
                    (a / m.delta_star_sigma)
                        .ln()
                        .abs()
                        .total_cmp(&(b / m.delta_star_sigma).ln().abs())
                })
                .unwrap();
            assert!(
                (share - 1.0 / (1.0 + 10.0 * nearest)).abs() < 1e-12,
                "{m:?}"
            );
        }

        let study = accuracy(&rows).expect("accuracy");
        let eps = study
            .knobs
            .iter()
            .find(|k| k.knob == "eps_d")
            .expect("an ε_d study");
        assert_eq!(
            eps.recommended,
            Some(1e-7),
            "τ_c grows with ε_d here: the tightest is cheapest"
        );
        assert!(
            !eps.settings.last().unwrap().safe,
            "ε_d = 1e-2 found overlaps"
        );
    }

    #[test]
    fn a_database_without_the_points_says_which_are_missing() {
        // Only Fig. 7's corners: two X0, LL and NNL, no sweep over X0, ε_d or Δ_NNL.
        let rows: Vec<EdmdRow> = [0.5, 2.0]
            .into_iter()
            .flat_map(|x0| {
                ["ll", "nnl"].map(|nb| EdmdRow {
                    tau_c_us: 40.0,
                    ..run(x0, 0.4, nb)
                })
            })
            .collect();
        let dir = tempfile::tempdir().expect("a temporary directory");
        let path = dir.path().join("empty.png");
        let unit = LengthUnit::SemiAxis;
        let errors = [
            fig8(&rows, Some(&path)).err(),
            fig9(&rows, unit, Some(&path)).err(),
            fig10(&rows, unit, Some(&path)).err(),
            fig11(&rows, &[], unit, Some(&path)).err(),
            accuracy(&rows).err(),
        ];
        for (error, needle) in errors.into_iter().zip([
            "φ = 0.3 over three or more X0",
            "over two or more ε_d",
            "X0 = 0.5, φ = 0.45",
            "located Δ*_NNL at X0 = 0.5",
            "eps_d",
        ]) {
            match error {
                Some(e @ ReportError::MissingPoints { .. }) => {
                    let text = e.to_string();
                    assert!(text.contains(needle), "{needle:?} not in {text}");
                    assert!(text.contains("edmd-figures.toml"), "{text}");
                }
                other => panic!("expected missing points, got {other:?}"),
            }
        }
        assert!(!path.exists(), "no empty figure was written");
    }
}

/// Figure 13 over a synthetic superquadric campaign shaped like its part of
/// `deploy/plans/edmd-figures.toml`, with a law whose answers are known.
mod superquadric_figure {
    use report::{EdmdRow, ReportError, fig13};

    const P: [f64; 6] = [2.0, 3.0, 4.0, 6.0, 8.0, 10.0];

    fn run(
        shape: &str,
        exponents: Option<[f64; 3]>,
        x0: f64,
        neighbours: &str,
        tau_c_us: f64,
    ) -> EdmdRow {
        EdmdRow {
            shape: shape.into(),
            x0,
            exponents,
            neighbours: neighbours.into(),
            delta_nnl: 0.06,
            n: 512,
            phi: 0.256,
            tau_c_us,
            eps_d: 1e-5,
            eps_nnl: 5e-3,
            nr_tol: 1e-12,
            nr_max_iter: 50,
            nr_relax: 0.5,
            sd_max_iter: 200,
            sd_tol: 1e-3,
            brent_tol: 1e-12,
            collisions: 20_000,
            ..Default::default()
        }
    }

    /// τ_c = base·(1 + (p − 2)/4), base 100 µs with LL and 60 µs with NNL at X0 = 2 (half that at
    /// X0 = 0.5); hard ellipsoids take a fifth (LL) and a sixth (NNL) of the p = 2 time. Around
    /// them, runs the figure must leave out.
    fn campaign() -> Vec<EdmdRow> {
        let mut rows = Vec::new();
        for x0 in [0.5, 2.0] {
            let scale = if x0 > 1.0 { 1.0 } else { 0.5 };
            for (method, base, slower) in [("ll", 100.0, 5.0), ("nnl", 60.0, 6.0)] {
                for p in P {
                    let mut sq = run(
                        "superquadric",
                        Some([2.0, 2.0, p]),
                        x0,
                        method,
                        scale * base * (1.0 + (p - 2.0) / 4.0),
                    );
                    sq.overlaps = u64::from(p == 10.0);
                    rows.push(sq);
                }
                rows.push(run("ellipsoid", None, x0, method, scale * base / slower));
                // Off the figure: another accuracy knob, another n, an ellipsoid with other knobs.
                rows.push(EdmdRow {
                    eps_d: 1e-3,
                    ..run("superquadric", Some([2.0, 2.0, 4.0]), x0, method, 1e6)
                });
                rows.push(run("superquadric", Some([4.0, 2.0, 4.0]), x0, method, 1e6));
                rows.push(EdmdRow {
                    nr_tol: 1e-6,
                    ..run("ellipsoid", None, x0, method, 1e-3)
                });
            }
        }
        rows
    }

    #[test]
    fn fig13_follows_its_law_and_renders() {
        let dir = tempfile::tempdir().expect("a temporary directory");
        let rows = campaign();
        let figure = fig13(&rows, None).expect("fig13");
        assert!(figure.missing.is_empty(), "{:?}", figure.missing);
        assert_eq!(figure.curves.len(), 4, "X0 = 0.5, 2 with LL and NNL");
        for c in &figure.curves {
            let xs: Vec<f64> = c.points.iter().map(|p| p.x).collect();
            assert_eq!(xs, P, "{c:?}");
            let base = if c.neighbours == "ll" { 100.0 } else { 60.0 }
                * if c.x0 > 1.0 { 1.0 } else { 0.5 };
            for p in &c.points {
                assert!(
                    (p.tau_c_us - base * (1.0 + (p.x - 2.0) / 4.0)).abs() < 1e-9,
                    "{c:?}"
                );
                assert_eq!(p.runs, 1, "the off-baseline runs are left out: {c:?}");
            }
            assert_eq!(c.flagged, [10.0], "{c:?}");
            assert_eq!(c.delta_nnl_sigma.is_some(), c.neighbours == "nnl");
        }
        assert_eq!(figure.ellipsoid_ratios.len(), 4);
        for r in &figure.ellipsoid_ratios {
            let expected = if r.neighbours == "ll" { 5.0 } else { 6.0 };
            assert!((r.ratio - expected).abs() < 1e-12, "{r:?}");
            assert_eq!((r.superquadric_runs, r.ellipsoid_runs), (1, 1), "{r:?}");
        }
        assert_eq!(figure.paper_ratio, [5.0, 6.0]);
        let json = serde_json::to_value(&figure).expect("serialises");
        assert!(json["ellipsoid_ratios"][0]["ratio"].is_number(), "{json}");

        for extension in ["png", "svg"] {
            let path = dir.path().join(format!("fig13.{extension}"));
            fig13(&rows, Some(&path)).expect("renders");
            let bytes = std::fs::metadata(&path).expect("written").len();
            assert!(bytes > 10_000, "{extension}: {bytes} bytes");
            if extension == "png" {
                image::open(&path).expect("the PNG decodes");
            } else {
                let text = std::fs::read_to_string(&path).expect("the SVG is text");
                for label in [
                    "p, the exponent of |z/c|^p in Eq. 77",
                    "τ_c (µs, wall time)",
                    "linked cells (LL)",
                    "neighbour lists (NNL)",
                    "τ_c(p = 2)/τ_c(HE) = 5.00",
                    "τ_c(p = 2)/τ_c(HE) = 6.00",
                    "at least 5–6 times slower",
                    "overlaps or solver failures",
                ] {
                    assert!(text.contains(label), "fig13.svg lacks {label:?}");
                }
            }
        }
    }

    #[test]
    fn fig13_names_the_points_a_database_lacks() {
        // Only p = 2 with LL at X0 = 0.5, and no hard-ellipsoid reference: drawn, the rest listed.
        let rows = vec![run("superquadric", Some([2.0, 2.0, 2.0]), 0.5, "ll", 50.0)];
        let figure = fig13(&rows, None).expect("one point is a figure");
        assert!(figure.ellipsoid_ratios.is_empty());
        let missing = figure.missing.join("\n");
        assert!(missing.contains("superquadric LL at X0 = 0.5, φ = 0.256, N = 512 with exponents [2, 2, p] for p = 3, 4, 6, 8, 10"), "{missing}");
        assert!(missing.contains("superquadric NNL at X0 = 2, φ = 0.256, N = 512 with exponents [2, 2, p] for p = 2, 3, 4, 6, 8, 10"), "{missing}");
        assert!(missing.contains("ellipsoid LL at X0 = 0.5, φ = 0.256, N = 512 with the knobs of its superquadric runs"), "{missing}");
        assert_eq!(figure.missing.len(), 5, "{missing}");

        // Ellipsoids only: nothing to draw, an error naming all four curves, and no file.
        let dir = tempfile::tempdir().expect("a temporary directory");
        let path = dir.path().join("fig13.png");
        let ellipsoids = vec![run("ellipsoid", None, 0.5, "ll", 10.0)];
        match fig13(&ellipsoids, Some(&path)) {
            Err(e @ ReportError::MissingPoints { .. }) => {
                let text = e.to_string();
                assert!(text.starts_with("fig13: nothing to draw"), "{text}");
                assert_eq!(
                    text.matches("with exponents [2, 2, p] for p = 2, 3, 4, 6, 8, 10")
                        .count(),
                    4,
                    "{text}"
                );
                assert!(text.contains("edmd-figures.toml"), "{text}");
            }
            other => panic!("expected missing points, got {other:?}"),
        }
        assert!(!path.exists(), "no empty figure was written");
    }
}

/// Fig. 11 from `[[tune]]` searches alone: their minima count as located, are drawn as curves of
/// their own, and a range end is drawn as a bound.
mod fig11_from_searches {
    use report::{LengthUnit, LocatedMinimum, MinimumMethod, fig11};

    fn searched(x0: f64, phi: f64, delta: f64, bracketed: bool) -> LocatedMinimum {
        LocatedMinimum {
            x0,
            phi,
            n: 256,
            delta_star: delta,
            delta_star_sigma: delta,
            interval: Some([0.8 * delta, 1.25 * delta]),
            tau_c_us: 20.0,
            bracketed,
            method: MinimumMethod::Search,
            grid: [0.02, 1.5],
            update_share: None,
        }
    }

    #[test]
    fn searched_minima_alone_make_the_figure() {
        let mut minima = Vec::new();
        for x0 in [0.5, 2.0] {
            for phi in [0.40, 0.55] {
                minima.push(searched(x0, phi, 0.05 / phi, true));
            }
        }
        minima.push(searched(2.0, 0.3, 1.5, false));
        let dir = tempfile::tempdir().expect("a temporary directory");
        let path = dir.path().join("fig11.svg");
        let f = fig11(&[], &minima, LengthUnit::Sigma, Some(&path)).expect("fig11");
        assert_eq!(f.minima, minima);
        // Two φ at each of the paper's X0 and two X0 at each of the right panel's φ.
        assert!(f.missing.is_empty(), "{:?}", f.missing);
        let f = fig11(&[], &minima[1..], LengthUnit::Sigma, None).expect("fig11");
        assert!(
            f.missing.iter().any(|m| m.contains("X0 = 0.5 for two")),
            "{:?}",
            f.missing
        );
        let svg = std::fs::read_to_string(&path).expect("the figure");
        assert!(
            svg.contains("X0 = 2, N = 256 (search)"),
            "the search's curve is labelled"
        );
        assert!(
            !svg.contains("X0 = 2, N = 256<"),
            "no grid curve without a grid"
        );
    }

    #[test]
    fn only_bounds_are_not_a_figure() {
        let bound = searched(2.0, 0.4, 1.5, false);
        assert!(fig11(&[], &[bound], LengthUnit::Sigma, None).is_err());
    }
}
