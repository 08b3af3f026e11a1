//! Unit tests of the scene generator: config validation, the exit policy, scaled scenes.

use super::*;

#[test]
fn config_validation_names_the_field() {
    let mut c = SynthConfig::default();
    c.noise.miss_rate = 1.5;
    assert!(matches!(
        Scene::new(c).unwrap_err(),
        SynthError::OutOfRange {
            field: "noise.miss_rate",
            ..
        }
    ));
    let c = SynthConfig {
        width: 4,
        ..SynthConfig::default()
    };
    assert!(matches!(
        Scene::new(c).unwrap_err(),
        SynthError::InvalidSize { .. }
    ));
    let mut c = SynthConfig::default();
    c.motion.speed = (5.0, 1.0);
    assert!(matches!(
        Scene::new(c).unwrap_err(),
        SynthError::EmptyRange { .. }
    ));
    let mut c = SynthConfig::default();
    c.motion.radius.0 = f64::NAN;
    assert!(Scene::new(c).is_err());
    let c = SynthConfig {
        shapes: 5000,
        motion: MotionConfig {
            radius: (400.0, 500.0),
            ..MotionConfig::default()
        },
        ..SynthConfig::default()
    };
    assert!(matches!(
        Scene::new(c).unwrap_err(),
        SynthError::TooLarge { .. }
    ));
}

#[test]
fn exit_policy_replaces_objects_with_new_ids() {
    let mut c = SynthConfig::with_seed(3);
    c.frames = 300;
    c.motion.speed = (5.0, 8.0);
    let sc = Scene::new(c).unwrap();
    let mut max_id = 0;
    let mut alive = Vec::new();
    for f in sc {
        max_id = max_id.max(f.gt.iter().map(|g| g.id).max().unwrap_or(0));
        alive.push(f.gt.len());
    }
    assert!(max_id > 10, "some objects left and were replaced");
    assert!(alive.iter().all(|&n| n <= 10));
    assert!(alive.iter().filter(|&&n| n >= 7).count() > 200);
}

/// The demo at 1920×1080 is the demo 1.5× larger: the frames have the new size, the shapes
/// are about 1.5× wider, as many are in view, and a size the scene refuses stays refused.
#[test]
fn scaled_scene_keeps_its_look() {
    // Mean √(full area) of the objects in view, and mean count in view, over 60 frames.
    let stats = |c: SynthConfig| {
        let (mut size, mut n, mut frames) = (0.0, 0.0, 0.0);
        for f in Scene::new(c).unwrap().take(60) {
            assert!(f.image.len() == 3 * (f.width * f.height) as usize);
            for g in &f.gt {
                size += (g.full_area as f64).sqrt();
                n += 1.0;
            }
            frames += 1.0;
        }
        (size / n, n / frames)
    };
    let (size, count) = stats(SynthConfig::demo());
    let big = SynthConfig::demo().scaled_to(1920, 1080);
    assert_eq!((big.width, big.height), (1920, 1080));
    let (big_size, big_count) = stats(big);
    let ratio = big_size / size;
    assert!((1.35..1.65).contains(&ratio), "size ratio {ratio}");
    assert!(
        (big_count - count).abs() <= 0.25 * count,
        "{count} vs {big_count}"
    );
    // The same scene at its own size is unchanged.
    assert_eq!(
        SynthConfig::demo().scaled_to(1280, 720),
        SynthConfig::demo()
    );
    let mut c = SynthConfig::default();
    c.occlusion.rects.push(OccluderRect {
        x: 320,
        y: 240,
        w: 64,
        h: 48,
    });
    let c = c.scaled_to(1280, 960);
    assert_eq!(
        c.occlusion.rects[0],
        OccluderRect {
            x: 640,
            y: 480,
            w: 128,
            h: 96
        }
    );
    assert!(matches!(
        Scene::new(SynthConfig::demo().scaled_to(8, 8)).unwrap_err(),
        SynthError::InvalidSize { .. }
    ));
}
