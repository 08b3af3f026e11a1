//! Unit tests of `detect::background` (a file of their own: the module's code is long enough).

use super::*;

fn frame_with_square(w: u32, h: u32, sq: Option<(u32, u32, u32)>, c: usize) -> Vec<u8> {
    let mut buf = vec![0u8; (w * h) as usize * c];
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize * c;
            let inside =
                sq.is_some_and(|(sx, sy, s)| x >= sx && x < sx + s && y >= sy && y < sy + s);
            let v = if inside {
                [240, 240, 60]
            } else {
                [100, 110, 120]
            };
            buf[i..i + 3].copy_from_slice(&v);
            if c == 4 {
                buf[i + 3] = 255;
            }
        }
    }
    buf
}

#[test]
fn finds_a_square_after_initialisation() {
    let mut bs = BackgroundSubtractor::new(BackgroundConfig {
        init_frames: 3,
        ..BackgroundConfig::default()
    })
    .unwrap();
    let empty = frame_with_square(64, 48, None, 3);
    assert_eq!(bs.warmup(), (0, 3));
    for i in 0..3 {
        let f = Frame::rgb(&empty, 64, 48).unwrap();
        assert!(bs.detect(&f).unwrap().is_empty());
        assert_eq!(
            bs.warmup(),
            (i + 1, 3),
            "warm-up progress after frame {}",
            i + 1
        );
    }
    assert!(bs.is_ready());
    let img = frame_with_square(64, 48, Some((10, 12, 15)), 3);
    let d = bs.detect(&Frame::rgb(&img, 64, 48).unwrap()).unwrap();
    assert_eq!(d.len(), 1);
    assert_eq!(d[0].bbox, crate::frame::BBox::new(10.0, 12.0, 15.0, 15.0));
    assert_eq!(d[0].mask.as_ref().unwrap().area(), 225);
    assert!(d[0].score > 0.0 && d[0].score <= 1.0);
    assert_eq!(bs.warmup(), (3, 3), "stays complete once learnt");
    bs.reset();
    assert_eq!(bs.warmup(), (0, 3), "a reset learns again");
}

#[test]
fn size_change_is_a_typed_error() {
    let mut bs = BackgroundSubtractor::new(BackgroundConfig::default()).unwrap();
    let a = frame_with_square(32, 32, None, 3);
    bs.detect(&Frame::rgb(&a, 32, 32).unwrap()).unwrap();
    let b = frame_with_square(32, 16, None, 3);
    assert_eq!(
        bs.detect(&Frame::rgb(&b, 32, 16).unwrap()).unwrap_err(),
        DetectError::SizeChanged {
            expected_width: 32,
            expected_height: 32,
            width: 32,
            height: 16
        }
    );
    bs.reset();
    assert!(bs.detect(&Frame::rgb(&b, 32, 16).unwrap()).is_ok());
}

#[test]
fn shadows_are_suppressed_when_asked() {
    let (w, h) = (40u32, 30u32);
    let bg = frame_with_square(w, h, None, 3);
    let mut shadowed = bg.clone();
    // A darker copy of the background (same chromaticity) over a 12×12 square.
    for y in 5..17 {
        for x in 5..17 {
            let i = (y * w + x) as usize * 3;
            for c in 0..3 {
                shadowed[i + c] = (bg[i + c] as f32 * 0.6) as u8;
            }
        }
    }
    for (shadow, expect) in [(None, 1), (Some(ShadowConfig::default()), 0)] {
        let mut bs = BackgroundSubtractor::new(BackgroundConfig {
            init_frames: 1,
            shadow,
            ..BackgroundConfig::default()
        })
        .unwrap();
        bs.detect(&Frame::rgb(&bg, w, h).unwrap()).unwrap();
        let d = bs.detect(&Frame::rgb(&shadowed, w, h).unwrap()).unwrap();
        assert_eq!(d.len(), expect, "{shadow:?}");
    }
}

#[test]
fn invalid_settings_are_rejected() {
    for cfg in [
        BackgroundConfig {
            alpha: 0.0,
            ..BackgroundConfig::default()
        },
        BackgroundConfig {
            init_frames: 0,
            ..BackgroundConfig::default()
        },
        BackgroundConfig {
            threshold: f32::NAN,
            ..BackgroundConfig::default()
        },
        BackgroundConfig {
            shadow: Some(ShadowConfig {
                min_ratio: 0.9,
                max_ratio: 0.5,
                max_chroma: 0.1,
            }),
            ..BackgroundConfig::default()
        },
    ] {
        assert!(matches!(
            BackgroundSubtractor::new(cfg),
            Err(DetectError::InvalidConfig { .. })
        ));
    }
}
