//! `shapetrack synth` writes a MOTChallenge-layout sequence that reads back with the project's
//! own readers and matches the in-memory scene exactly.
// A native suite (`cargo test`); for wasm32 (`wasm-pack test --node`) it compiles to nothing:
// the wasm suites are the `wasm_*` and `*_wasm` files.
#![cfg(not(target_arch = "wasm32"))]

use shapetrack::io::motchallenge::{parse_mot, parse_mots, SeqInfo};
use shapetrack::io::read_text;
use shapetrack::synth::{Scene, SynthConfig};
use std::path::PathBuf;
use std::process::Command;

fn out_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("shapetrack-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

#[test]
fn synth_writes_a_sequence_that_reads_back() {
    let dir = out_dir("synth-cli");
    let status = Command::new(env!("CARGO_BIN_EXE_shapetrack"))
        .args(["synth", "--seed", "5", "--frames", "12", "--shapes", "4"])
        .args(["--width", "320", "--height", "240", "--out"])
        .arg(&dir)
        .status()
        .unwrap();
    assert!(status.success());

    let info = SeqInfo::read(&dir.join("seqinfo.ini")).unwrap();
    assert_eq!(
        (
            info.seq_length,
            info.im_width,
            info.im_height,
            info.frame_rate
        ),
        (12, 320, 240, 25.0)
    );
    assert_eq!(
        (info.im_dir.as_str(), info.im_ext.as_str()),
        ("img1", ".png")
    );

    let read = |p: &str| read_text(&dir.join(p)).unwrap();
    let gt = parse_mot(&read("gt/gt.txt"), "gt.txt").unwrap();
    let gt_mots = parse_mots(&read("gt/gt_mots.txt"), "gt_mots.txt").unwrap();
    let det = parse_mot(&read("det/det.txt"), "det.txt").unwrap();
    let det_mots = parse_mots(&read("det/det_mots.txt"), "det_mots.txt").unwrap();
    let jitter = parse_mot(&read("det/det_jitter.txt"), "det_jitter.txt").unwrap();

    // The same configuration in memory gives the same sequence.
    let scene = Scene::new(SynthConfig {
        frames: 12,
        shapes: 4,
        width: 320,
        height: 240,
        ..SynthConfig::with_seed(5)
    })
    .unwrap();
    let (mut ngt, mut ndet) = (0, 0);
    for f in scene {
        let img = image::open(dir.join(format!("img1/{:06}.png", f.index)))
            .unwrap()
            .to_rgb8();
        assert_eq!(img.dimensions(), (320, 240));
        assert_eq!(img.as_raw(), &f.image, "frame {} pixels", f.index);

        let rows: Vec<_> = gt.iter().filter(|r| r.frame == f.index).collect();
        let masks: Vec<_> = gt_mots.iter().filter(|r| r.frame == f.index).collect();
        assert_eq!(rows.len(), f.gt.len());
        assert_eq!(masks.len(), f.gt.len());
        for ((r, m), g) in rows.iter().zip(&masks).zip(&f.gt) {
            assert_eq!(
                (r.id, r.bbox, r.score, r.class),
                (g.id as i64, g.bbox, 1.0, 1)
            );
            assert_eq!(r.visibility, g.visibility);
            assert_eq!((m.id, m.class), (g.id as i64, 1));
            assert_eq!(m.mask_bitmap().as_ref(), Some(&g.mask));
        }
        ngt += rows.len();

        let d: Vec<_> = det.iter().filter(|r| r.frame == f.index).collect();
        let dm: Vec<_> = det_mots.iter().filter(|r| r.frame == f.index).collect();
        let dj: Vec<_> = jitter.iter().filter(|r| r.frame == f.index).collect();
        assert_eq!(d.len(), f.detections.len());
        assert_eq!(dm.len(), f.detections.len());
        assert_eq!(dj.len(), f.detections.len());
        for (((r, m), j), x) in d.iter().zip(&dm).zip(&dj).zip(&f.detections) {
            assert_eq!((r.id, r.bbox, r.score), (-1, x.bbox, x.score));
            assert_eq!(
                m.mask_bitmap(),
                x.mask,
                "det_mots line matches det.txt line"
            );
            assert_eq!(m.bbox, r.bbox);
            assert_eq!((j.id, j.score), (-1, x.score));
        }
        ndet += d.len();
    }
    assert_eq!(gt.len(), ngt);
    assert_eq!(det.len(), ndet);
    assert!(ngt > 30 && ndet > 30);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn synth_rejects_bad_settings_with_a_message() {
    let dir = out_dir("synth-cli-bad");
    let out = Command::new(env!("CARGO_BIN_EXE_shapetrack"))
        .args(["synth", "--seed", "1", "--miss-rate", "2", "--out"])
        .arg(&dir)
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("noise.miss_rate"), "{err}");
}

#[test]
fn synth_presets_apply_and_flags_override_them() {
    let dir = out_dir("synth-cli-preset");
    let status = Command::new(env!("CARGO_BIN_EXE_shapetrack"))
        .args([
            "synth",
            "--seed",
            "3",
            "--preset",
            "occlusion",
            "--frames",
            "4",
            "--out",
        ])
        .arg(&dir)
        .status()
        .unwrap();
    assert!(status.success());
    let gt = parse_mot(&read_text(&dir.join("gt/gt.txt")).unwrap(), "gt.txt").unwrap();
    let scene = Scene::new(SynthConfig {
        frames: 4,
        ..SynthConfig::occlusion_scene(3)
    })
    .unwrap();
    let want: Vec<_> = scene.flat_map(|f| f.gt_records()).collect();
    assert_eq!(gt.len(), want.len());
    for (a, b) in gt.iter().zip(&want) {
        assert_eq!((a.frame, a.id, a.bbox), (b.frame, b.id, b.bbox));
    }
    std::fs::remove_dir_all(&dir).unwrap();
}
