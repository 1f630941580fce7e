//! `overlap::judge`, what `sweep overlap` answers for each configuration, against the exact
//! oracle (Eq. 2 in big rationals on the configuration as given): where a precision gives
//! kernel verdicts they are all the exact one, where it cannot it says why, and the exact
//! verdict is there either way. Cases are drawn near contact on purpose, down to exact touching.

mod common;

use common::exact_margin;
use num_traits::Signed;
use overlap::config::axes_from_quaternion;
use overlap::judge::{Case, judge};
use overlap::{Configuration, Cuboid, Kernels, min_distance};
use proptest::prelude::*;

/// A random frame, cuboid and centre, and a radius at relative gap `gap` from touching (0:
/// exactly the distance as computed in f64).
fn case(q: [f64; 4], half: [f64; 3], r_sc: [f64; 3], gap: f64) -> Case {
    let norm = q.iter().map(|x| x * x).sum::<f64>().sqrt();
    let axes = axes_from_quaternion(q.map(|x| x / norm));
    let distance = min_distance(&Configuration { r_sc, axes }, &Cuboid { half });
    let radius = if distance > 0.0 {
        distance * (1.0 + gap)
    } else {
        0.5
    };
    Case {
        r_sc,
        radius,
        half,
        axes,
    }
}

/// The exact verdict of the case as given, from the rational oracle.
fn oracle(case: &Case) -> bool {
    let margin = exact_margin(
        &Configuration {
            r_sc: case.r_sc,
            axes: case.axes,
        },
        &Cuboid { half: case.half },
        case.radius,
    );
    !margin.is_positive()
}

fn check<T: Kernels>(case: &Case) -> Result<(), TestCaseError> {
    let judgement = judge::<T>(case);
    let truth = oracle(case);
    prop_assert_eq!(judgement.exact, Ok(truth), "exact verdict of {:?}", case);
    match &judgement.kernels {
        Ok(verdicts) => {
            for (algorithm, verdict) in verdicts {
                prop_assert_eq!(
                    *verdict,
                    truth,
                    "{} in {} contradicts the exact verdict of {:?}",
                    algorithm.name(),
                    T::NAME,
                    case
                );
            }
        }
        Err(why) => prop_assert!(why.contains("within rounding"), "{why}"),
    }
    Ok(())
}

fn gap() -> impl Strategy<Value = f64> {
    prop_oneof![
        Just(0.0),
        (-17.0f64..-1.0, prop::bool::ANY).prop_map(|(e, above)| {
            let g = 10f64.powf(e);
            if above { g } else { -g }
        }),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    #[test]
    fn decided_cases_agree_with_the_exact_verdict_and_undecided_ones_say_why(
        q in prop::array::uniform4(-1.0f64..1.0).prop_filter("a rotation", |q| q.iter().map(|x| x * x).sum::<f64>() > 1e-3),
        half in prop::array::uniform3(0.05f64..5.0),
        r_sc in prop::array::uniform3(-8.0f64..8.0),
        gap in gap(),
    ) {
        let case = case(q, half, r_sc, gap);
        check::<f32>(&case)?;
        check::<f64>(&case)?;
    }
}

#[test]
fn a_touching_sphere_is_undecided_in_both_precisions_and_exactly_touching() {
    // The sphere touches the face x = 0.5 of an axis-aligned cuboid.
    let case = Case {
        r_sc: [1.5, 0.0, 0.0],
        radius: 1.0,
        half: [0.5, 1.0, 1.0],
        axes: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
    };
    for judgement in [judge::<f32>(&case), judge::<f64>(&case)] {
        assert_eq!(judgement.exact, Ok(true), "touching counts as overlapping");
        let why = judgement.kernels.expect_err("undecided");
        assert!(
            why.starts_with("radius: the sphere is within rounding"),
            "{why}"
        );
        assert_eq!(judgement.distance, 1.0);
    }
    // A hundredth of a radius away, both precisions decide, and say no.
    let apart = Case {
        radius: 0.99,
        ..case
    };
    for judgement in [judge::<f32>(&apart), judge::<f64>(&apart)] {
        let verdicts = judgement.kernels.expect("decided");
        assert!(verdicts.iter().all(|(_, v)| !v), "{verdicts:?}");
        assert_eq!(judgement.exact, Ok(false));
    }
}

#[test]
fn values_beyond_a_precision_leave_it_undecided_and_beyond_the_exact_range_say_so() {
    let far = Case {
        r_sc: [1e39, 0.0, 0.0],
        radius: 1.0,
        half: [0.5, 1.0, 1.0],
        axes: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
    };
    let f32 = judge::<f32>(&far);
    let why = f32.kernels.expect_err("beyond f32");
    assert!(
        why.starts_with("rx: ") && why.contains("is beyond what f32 can square"),
        "{why}"
    );
    // f64 squares 1e39 fine and the sphere is far from the cuboid.
    assert!(
        judge::<f64>(&far)
            .kernels
            .expect("decided")
            .iter()
            .all(|(_, v)| !v)
    );
    // The filter decides it without exact arithmetic: the margin is far outside its band.
    assert_eq!(f32.exact, Ok(false));
}
