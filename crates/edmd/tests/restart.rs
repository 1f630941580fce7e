//! Restarts: a run continued from its state file is, bit for bit, the run that never stopped;
//! checkpoints and trajectory frames do not change a run.

use edmd::{
    FinalState, FrameEvery, Hooks, Neighbours, SavedState, Scene, ShapeKind, run_with_hooks,
};

fn scene(shape: ShapeKind, neighbours: Neighbours, collisions: u64) -> Scene {
    let mut s = Scene::new(
        shape,
        256,
        if shape == ShapeKind::Sphere {
            0.45
        } else {
            0.3
        },
    );
    if shape == ShapeKind::Ellipsoid {
        s.x0 = 2.0;
    }
    s.neighbours = neighbours;
    s.delta_nnl = edmd::default_delta_nnl(shape, neighbours);
    s.equilibrate = 0;
    s.collisions = collisions;
    s.seed = 7;
    s
}

/// Runs `scene` (from `from` if given) and returns its final state with every state handed
/// to `on_state` (checkpoints every `checkpoint_every`, then the end), encoded.
fn run(
    scene: &Scene,
    from: Option<&[u8]>,
    checkpoint_every: u64,
) -> (FinalState, Vec<(f64, Vec<u8>)>) {
    let mut saved = Vec::new();
    let mut on_state = |s: &SavedState| {
        saved.push((s.time(), s.to_bytes().map_err(|e| e.to_string())?));
        Ok(())
    };
    let hooks = Hooks {
        from: from.map(|b| SavedState::from_bytes(b).expect("state decodes")),
        checkpoint_every,
        save_final: true,
        on_state: Some(&mut on_state),
        ..Hooks::default()
    };
    let (report, state) = run_with_hooks(scene, &mut |_| {}, hooks).expect("run");
    assert_eq!(report.overlaps, 0);
    (state, saved)
}

/// Every f64 of two final states, compared by its bits.
fn assert_same_bits(a: &FinalState, b: &FinalState, what: &str) {
    assert_eq!(a.particles.len(), b.particles.len());
    for (i, (p, q)) in a.particles.iter().zip(&b.particles).enumerate() {
        let bits = |x: &edmd::ParticleDump| -> Vec<u64> {
            x.position
                .iter()
                .chain(x.orientation.iter().flatten())
                .chain(&x.velocity)
                .chain(&x.angular_velocity)
                .map(|v| v.to_bits())
                .collect()
        };
        assert_eq!(bits(p), bits(q), "{what}: body {i} differs");
    }
}

/// K + K collisions through a state file against 2K in one go, and from a checkpoint in the
/// middle of the first half against the same.
fn continues_bit_for_bit(shape: ShapeKind, neighbours: Neighbours, k: u64) {
    let what = format!("{shape:?} {neighbours:?}");
    let (whole, whole_saved) = run(&scene(shape, neighbours, 2 * k), None, 0);
    let (_, first_saved) = run(&scene(shape, neighbours, k), None, k / 4);
    // Checkpoints at k/4, k/2, 3k/4, k, then the end (k again).
    assert_eq!(first_saved.len(), 5, "{what}");
    let (end_time, end_bytes) = first_saved.last().expect("the final state");
    let (continued, continued_saved) = run(&scene(shape, neighbours, k), Some(end_bytes), 0);
    assert_same_bits(&whole, &continued, &what);
    let clock = |v: &[(f64, Vec<u8>)]| v.last().map(|(t, _)| t.to_bits());
    assert_eq!(
        clock(&whole_saved),
        clock(&continued_saved),
        "{what}: clock"
    );
    assert!(*end_time > 0.0);
    // From the checkpoint at k/4: 7k/4 more.
    let (_, quarter) = &first_saved[0];
    let (from_quarter, _) = run(&scene(shape, neighbours, 7 * k / 4), Some(quarter), 0);
    assert_same_bits(&whole, &from_quarter, &format!("{what} from k/4"));
}

#[test]
fn spheres_continue_bit_for_bit_with_lists_and_cells() {
    continues_bit_for_bit(ShapeKind::Sphere, Neighbours::Nnl, 100_000);
    continues_bit_for_bit(ShapeKind::Sphere, Neighbours::Ll, 20_000);
}

#[test]
fn ellipsoids_continue_bit_for_bit_with_cells_and_lists() {
    continues_bit_for_bit(ShapeKind::Ellipsoid, Neighbours::Ll, 20_000);
    continues_bit_for_bit(ShapeKind::Ellipsoid, Neighbours::Nnl, 8_000);
}

#[test]
fn a_run_rebuilt_from_the_state_parts_from_the_continuous_one() {
    // The check above could pass trivially if runs did not depend on where bodies were
    // advanced; the same collisions as one run with the state taken from a run that was
    // advanced to the present first (a rebuild, by changing Δ_NNL) part from it.
    let s = scene(ShapeKind::Sphere, Neighbours::Nnl, 5_000);
    let (whole, _) = run(&scene(ShapeKind::Sphere, Neighbours::Nnl, 10_000), None, 0);
    let (_, saved) = run(&s, None, 0);
    let other = Scene {
        delta_nnl: 0.3,
        ..s.clone()
    };
    let (rebuilt, _) = run(&other, Some(&saved[0].1), 0);
    assert_ne!(
        whole.particles[0].position.map(f64::to_bits),
        rebuilt.particles[0].position.map(f64::to_bits)
    );
}

#[test]
fn another_system_is_refused_naming_the_key() {
    let s = scene(ShapeKind::Sphere, Neighbours::Nnl, 1_000);
    let (_, saved) = run(&s, None, 0);
    let bytes = &saved[0].1;
    for (other, key) in [
        (
            Scene {
                n: 300,
                ..s.clone()
            },
            "`n`",
        ),
        (
            Scene {
                phi: 0.4,
                ..s.clone()
            },
            "`phi`",
        ),
        (
            scene(ShapeKind::Ellipsoid, Neighbours::Nnl, 1_000),
            "`shape`",
        ),
    ] {
        let hooks = Hooks {
            from: Some(SavedState::from_bytes(bytes).expect("decodes")),
            ..Hooks::default()
        };
        let err = run_with_hooks(&other, &mut |_| {}, hooks)
            .expect_err("refused")
            .to_string();
        assert!(err.contains(key), "{err}");
    }
    assert!(SavedState::from_bytes(&bytes[..bytes.len() / 2]).is_err());
    assert!(SavedState::from_bytes(b"not a state").is_err());
}

#[test]
fn frames_do_not_perturb_the_run_and_see_every_step() {
    let s = scene(ShapeKind::Ellipsoid, Neighbours::Ll, 4_000);
    let (plain, _) = run(&s, None, 0);
    let mut steps = Vec::new();
    let mut on_frame = |f: &edmd::Frame| {
        assert_eq!(f.bodies.len(), 256);
        assert!(f.bodies.iter().all(|b| b.t == f.time));
        steps.push(f.step);
        Ok(())
    };
    let hooks = Hooks {
        frame_every: FrameEvery::Collisions(1_000),
        on_frame: Some(&mut on_frame),
        ..Hooks::default()
    };
    let (_, framed) = run_with_hooks(&s, &mut |_| {}, hooks).expect("run");
    assert_same_bits(&plain, &framed, "with frames");
    assert_eq!(steps, vec![0, 1_000, 2_000, 3_000, 4_000]);
}

#[test]
fn a_failing_hook_stops_the_run_with_its_message() {
    let s = scene(ShapeKind::Sphere, Neighbours::Nnl, 2_000);
    let mut on_frame = |f: &edmd::Frame| {
        if f.step >= 1_000 {
            Err("disk full".to_string())
        } else {
            Ok(())
        }
    };
    let hooks = Hooks {
        frame_every: FrameEvery::Collisions(500),
        on_frame: Some(&mut on_frame),
        ..Hooks::default()
    };
    let err = run_with_hooks(&s, &mut |_| {}, hooks).expect_err("stops");
    assert!(err.to_string().contains("disk full"), "{err}");
}

/// Frames at a time interval: one at the first collision at or after each multiple of it, the
/// bodies at that collision's time; the run is the same with them.
#[test]
fn time_frames_come_at_the_first_collision_after_each_interval() {
    let s = scene(ShapeKind::Sphere, Neighbours::Nnl, 20_000);
    let (plain, _) = run(&s, None, 0);
    let mut times = Vec::new();
    let mut on_frame = |f: &edmd::Frame| {
        assert!(f.bodies.iter().all(|b| b.t == f.time));
        times.push(f.time);
        Ok(())
    };
    let dt = 0.05;
    let hooks = Hooks {
        frame_every: FrameEvery::Time(dt),
        on_frame: Some(&mut on_frame),
        ..Hooks::default()
    };
    let (_, framed) = run_with_hooks(&s, &mut |_| {}, hooks).expect("run");
    assert_same_bits(&plain, &framed, "with time frames");
    let t0 = times[0];
    assert!(times.len() > 5, "{times:?}");
    for (k, t) in times.iter().enumerate().skip(1) {
        let due = t0 + k as f64 * dt;
        // At or after its multiple, and before the next one (256 spheres collide far more
        // often than every 0.05).
        assert!(
            *t >= due - 1e-12 && *t < due + dt,
            "frame {k} at {t}, due {due}"
        );
    }
}

/// A state file as an older version wrote it: every map entry `newer` names dropped, the version
/// set to `version`; how many entries it dropped.
fn as_version(
    v: &mut ciborium::Value,
    version: u32,
    newer: &dyn Fn(&ciborium::Value, &ciborium::Value) -> bool,
) -> usize {
    use ciborium::Value;
    match v {
        Value::Map(entries) => {
            let before = entries.len();
            entries.retain(|(k, val)| !newer(k, val));
            let mut dropped = before - entries.len();
            for (k, val) in entries.iter_mut() {
                if matches!(k, Value::Text(t) if t == "version") {
                    *val = Value::Integer(version.into());
                }
                dropped += as_version(val, version, newer);
            }
            dropped
        }
        Value::Array(items) => items
            .iter_mut()
            .map(|x| as_version(x, version, newer))
            .sum(),
        _ => 0,
    }
}

/// A state file of version 1, written before neighbour lists could spill past their room (no
/// `spill` and `free` in its lists), is read and continues as the version 2 file it differs from;
/// a later version is refused, naming it.
#[test]
fn a_version_1_state_file_continues_and_a_later_version_is_refused() {
    use ciborium::Value;
    let encode = |v: &Value| {
        let mut out = Vec::new();
        ciborium::into_writer(v, &mut out).expect("encodes");
        out
    };
    let k = 5_000;
    let (whole, _) = run(&scene(ShapeKind::Sphere, Neighbours::Nnl, 2 * k), None, 0);
    let (_, first) = run(&scene(ShapeKind::Sphere, Neighbours::Nnl, k), None, 0);
    let bytes = &first.last().expect("the final state").1;
    let mut v: Value = ciborium::from_reader(&bytes[..]).expect("CBOR");
    // Drops the empty `spill` and `free` of every list.
    let dropped = as_version(&mut v, 1, &|k, val| {
        matches!(k, Value::Text(t) if t == "spill" || t == "free")
            && matches!(val, Value::Array(a) if a.is_empty())
    });
    assert_eq!(dropped, 2, "no list spilled at the end of the first half");
    let v1 = encode(&v);
    let (continued, _) = run(&scene(ShapeKind::Sphere, Neighbours::Nnl, k), Some(&v1), 0);
    assert_same_bits(&whole, &continued, "from version 1");
    if let Value::Map(entries) = &mut v {
        for (key, val) in entries.iter_mut() {
            if matches!(key, Value::Text(t) if t == "version") {
                *val = Value::Integer((edmd::state::VERSION + 1).into());
            }
        }
    }
    let err = SavedState::from_bytes(&encode(&v))
        .err()
        .expect("a later version is refused")
        .to_string();
    assert!(
        err.contains(&format!("version {}", edmd::state::VERSION + 1)),
        "{err}"
    );
}

/// A rigid body's state keeps its pairs' separating axes (version 3), a sphere's has none; a
/// version 2 file of ellipsoids, which had neither them nor the collision count behind the
/// escape horizon (version 4), still continues (without the axes' starts and the count the run
/// is not the saved one's bit for bit, but it is a run: no overlap, the same collisions).
#[test]
fn an_ellipsoid_state_without_kept_axes_continues() {
    use ciborium::Value;
    let axes = |k: &Value, _: &Value| matches!(k, Value::Text(t) if t == "axes");
    let decode = |bytes: &[u8]| -> Value { ciborium::from_reader(bytes).expect("CBOR") };
    let k = 2_000;
    let (_, spheres) = run(&scene(ShapeKind::Sphere, Neighbours::Nnl, k), None, 0);
    let mut v = decode(&spheres.last().expect("the final state").1);
    assert_eq!(
        as_version(&mut v, 2, &axes),
        0,
        "a sphere's state keeps no axes"
    );
    let (_, first) = run(&scene(ShapeKind::Ellipsoid, Neighbours::Nnl, k), None, 0);
    let mut v = decode(&first.last().expect("the final state").1);
    let axes_and_pace =
        |k: &Value, v: &Value| axes(k, v) || matches!(k, Value::Text(t) if t == "pace");
    assert_eq!(
        as_version(&mut v, 2, &axes_and_pace),
        2,
        "an ellipsoid's state keeps its axes and its collision count"
    );
    let mut bytes = Vec::new();
    ciborium::into_writer(&v, &mut bytes).expect("encodes");
    let (continued, _) = run(
        &scene(ShapeKind::Ellipsoid, Neighbours::Nnl, k),
        Some(&bytes),
        0,
    );
    assert_eq!(continued.particles.len(), 256);
}
