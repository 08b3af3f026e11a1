use super::*;

fn shared() -> std::path::PathBuf {
    datasets::shared_dir()
}

#[test]
fn datasets_load_with_their_documented_sizes() {
    let d = load(&["mot15", "sportsmot", "bdd", "bdd-masks"], &shared()).unwrap();
    let frames = |d: &Dataset| d.sequences.iter().map(|s| s.num_frames).sum::<u32>();
    assert_eq!((d[0].sequences.len(), frames(&d[0])), (11, 5500));
    assert_eq!((d[1].sequences.len(), frames(&d[1])), (45, 28_574));
    // SportsMOT's ids start at 0 in the files and at 1 here.
    let min_id = d[1]
        .sequences
        .iter()
        .flat_map(|s| &s.gt)
        .map(|r| r.id)
        .min();
    assert_eq!(min_id, Some(1));
    assert!(d[0].sequences.iter().all(|s| s.real_dets.is_some()));
    assert!(d[1].sequences.iter().all(|s| s.real_dets.is_none()));
    // BDD100K: 202 frames at 5 fps; 2,301 real boxes; gt ids dense from 1.
    let b = &d[2].sequences[0];
    assert_eq!((b.num_frames, b.fps), (202, 5.0));
    assert_eq!(b.real_dets.as_ref().map(Vec::len), Some(2301));
    let ids: std::collections::BTreeSet<i64> = b.gt.iter().map(|r| r.id).collect();
    assert_eq!(ids.iter().next(), Some(&1));
    assert_eq!(*ids.iter().last().unwrap() as usize, ids.len());
    // BDD masks: the model's 1,567 masks, scores absent (1.0).
    let m = &d[3].sequences[0];
    let dets = m.real_dets.as_ref().unwrap();
    assert_eq!(dets.len(), 1567);
    assert!(dets.iter().all(|r| r.mask.is_some() && r.score == 1.0));
}

#[test]
fn cells_cover_every_profile_and_are_deterministic() {
    let d = load(&["mot15", "bdd-masks"], &shared()).unwrap();
    let c = cells(&d);
    let names: Vec<String> = c.iter().map(Cell::name).collect();
    assert!(names.contains(&"mot15/real".to_string()));
    assert!(names.contains(&"mot15/crowd".to_string()));
    assert!(names.contains(&"bdd-masks/real".to_string()));
    assert!(!names
        .iter()
        .any(|n| n.starts_with("bdd-masks/") && n != "bdd-masks/real"));
    assert_eq!(c.len(), 1 + box_models().len() + 1);
    let seq = &d[0].sequences[8];
    let a = detections("mot15", seq, "wide").unwrap();
    assert_eq!(a, detections("mot15", seq, "wide").unwrap());
    assert_ne!(a, detections("mot15", seq, "low").unwrap());
    assert_eq!(cell_seed("a", "b", "c"), cell_seed("a", "b", "c"));
    assert_ne!(cell_seed("a", "b", "c"), cell_seed("a", "b", "d"));
    assert!(matches!(
        detections("mot15", seq, "nope"),
        Err(GridError::UnknownModel(..))
    ));
    assert!(load(&["nope"], &shared()).is_err());
}

#[test]
fn a_cell_runs_online_and_offline_and_scores() {
    let d = load(&["mot15"], &shared()).unwrap();
    // TUD-Campus (71 frames) alone, real detections.
    let seq = d[0]
        .sequences
        .iter()
        .find(|s| s.name == "TUD-Campus")
        .unwrap();
    let data = CellData {
        cell: Cell::new("mot15", "real"),
        sequences: vec![(seq, detections("mot15", seq, "real").unwrap())],
    };
    for mode in [Mode::Online, Mode::Offline] {
        let r = run_cell(&data, &Tracking::defaults(mode, Input::Boxes)).unwrap();
        let s = r.summary().combined;
        assert!(s.hota > 20.0 && s.hota < 100.0, "{mode:?}: {}", s.hota);
    }
    // Perfect detections of the ground truth, tracked: near-perfect scores.
    let gt_dets: Vec<Record> = seq
        .gt
        .iter()
        .map(|r| Record {
            id: -1,
            ..r.clone()
        })
        .collect();
    let mut t = Tracking::defaults(Mode::Online, Input::Boxes);
    t.config.online.min_hits = 1;
    let res = track(seq, &gt_dets, &t).unwrap();
    let s = score(&[(seq, res)]).unwrap().summary().combined;
    assert!(s.hota > 90.0, "{}", s.hota);
}
