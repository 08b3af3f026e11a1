//! `shapetrack follow`: follow the target given by a binary PNG mask at one frame through a
//! folder of frames, forward and backward, and write MOTS txt; `shapetrack vot`: run the
//! follower under the VOT anchor and reset protocols and write the region files `eval-vot`
//! scores.
//!
//! Frames are decoded one at a time in the direction of travel, so memory stays flat over a
//! long folder, for `follow` and for `vot` (which decodes a frame each time one of its runs
//! reaches it rather than holding the sequence).

use crate::detect::{runner, Kind, ModelChoice, Runner};
use crate::netcache::{CachedNet, SharedNet};
use image::RgbImage;
use shapetrack::eval::vot::{anchors_every, run_anchor_protocol, run_reset_protocol};
use shapetrack::eval::vot::{overlap, OverlapMethod, ResetParams};
use shapetrack::follow::{
    mask_from_bitmap, rasterize_polygon, FollowConfig, FollowError, FollowStep, Follower,
};
use shapetrack::frame::{Detection, Frame, Mask};
use shapetrack::io::motchallenge::write_mots;
use shapetrack::io::png_masks::{read_png_mask_dir, EightBit, PngMaskSequence};
use shapetrack::io::rle::Rle;
use shapetrack::io::vot::{parse_anchor_values, read_regions, write_regions, Direction, Region};
use shapetrack::io::{image_files, read_rgb, write_text, Record};
use std::cell::RefCell;
use std::path::{Path, PathBuf};
use std::rc::Rc;
use std::time::{Duration, Instant};

/// Detections used while following.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum DetectorKind {
    /// None: the follower alone (keypoints, transform, colour).
    None,
    /// What `shapetrack detect --detector auto` runs without boxes: the adaptive background
    /// subtractor when the first frames show a static camera, the moving-camera detector
    /// otherwise; one detector per direction of travel.
    Auto,
}

/// Arguments of `shapetrack follow` (other scripts rely on these flags: do not rename).
#[derive(clap::Args)]
pub struct Args {
    /// Folder of frames (.jpg/.png, sorted by file name, numbered from 1).
    #[arg(long)]
    frames: PathBuf,
    /// Binary PNG mask of the target at --init-frame (non-zero = target), of the frames' size.
    #[arg(long)]
    init: PathBuf,
    /// Frame (1-based) the mask belongs to.
    #[arg(long, default_value_t = 1)]
    init_frame: usize,
    /// Detections to prefer when they agree with the followed mask.
    #[arg(long, value_enum, default_value = "none")]
    detector: DetectorKind,
    /// Output MOTS txt (`frame id class h w rle`; id 1, class 1).
    #[arg(long)]
    out: PathBuf,
    /// Also score the result: a folder of ground-truth PNG masks (non-zero = target), one per
    /// frame in name order; prints J (mean mask IoU over frames).
    #[arg(long)]
    gt: Option<PathBuf>,
    /// Follower settings as JSON (missing fields take their defaults), e.g.
    /// `'{"max_side": 480}'`.
    #[arg(long)]
    config: Option<String>,
    /// `copy` writes the initial mask unchanged in every frame: the baseline the follower is
    /// measured against.
    #[arg(long, value_enum, default_value = "follow")]
    method: Method,
    /// Print each frame's confidence, lost flag, inliers (and IoU with --gt).
    #[arg(long)]
    verbose: bool,
    /// The learned segmentation's model file (u2netp.onnx; found in the checkout's
    /// node_modules when absent), or `none` for the follower without it.
    #[arg(long)]
    model: Option<String>,
    /// Folder keeping the network's outputs between runs (evaluation only).
    #[arg(long)]
    net_cache: Option<PathBuf>,
}

/// The learned model for the follower, shared by its runs (`None`: weights-free).
fn shared_net(
    model: Option<&str>,
    cache: Option<PathBuf>,
    what: &str,
) -> Result<Option<SharedNet>, Box<dyn std::error::Error>> {
    Ok(match ModelChoice::from_flag(model).load(what)? {
        Some(n) => Some(SharedNet(Rc::new(RefCell::new(CachedNet::new(n, cache)?)))),
        None => None,
    })
}

fn frame_of(img: &RgbImage) -> Result<Frame<'_>, Box<dyn std::error::Error>> {
    Ok(Frame::rgb(img.as_raw(), img.width(), img.height())?)
}

/// Non-zero in any channel is target; in a paletted PNG, an index ≠ 0 (whatever its colour).
fn read_mask_png(path: &Path, width: u32, height: u32) -> Result<Mask, Box<dyn std::error::Error>> {
    // The frame's size is checked in the header, before the mask is decoded.
    let img = shapetrack::io::image_file::read_mask_image(path, Some((width, height)))
        .map_err(|e| format!("--init {e}"))?;
    let (iw, ih) = img.dimensions();
    let bits = img.object_bits(|i| {
        // 16 bits a channel: an 8-bit conversion would round ids 1…127 of a 16-bit mask to 0.
        i.to_rgb16()
            .pixels()
            .map(|p| u8::from(p.0.iter().any(|&v| v != 0)))
            .collect()
    });
    Ok(mask_from_bitmap(width, height, iw, ih, &bits)?)
}

/// What `follow` writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Method {
    /// The follower.
    Follow,
    /// The initial mask copied to every frame (a baseline).
    Copy,
}

/// One direction of travel: a follower and, with `--detector auto`, its own detector (its
/// background model must see the frames in order).
struct Travel {
    follower: Follower,
    detector: Option<Runner>,
    net: Option<SharedNet>,
}

impl Travel {
    fn new(
        frame: &Frame<'_>,
        mask: &Mask,
        kind: DetectorKind,
        cfg: &FollowConfig,
        net: Option<SharedNet>,
    ) -> Result<Travel, Box<dyn std::error::Error>> {
        let follower = Follower::new(frame, mask, cfg.clone())?;
        let detector = match kind {
            DetectorKind::None => None,
            DetectorKind::Auto => {
                let mut d = runner(Kind::Auto, None)?;
                d.detect(0, frame)?;
                Some(d)
            }
        };
        Ok(Travel {
            follower,
            detector,
            net,
        })
    }

    fn step(
        &mut self,
        frame: &Frame<'_>,
        busy: &mut Duration,
    ) -> Result<FollowStep, Box<dyn std::error::Error>> {
        let t = Instant::now();
        let dets: Vec<Detection> = match &mut self.detector {
            // The frame number only picks a frame's boxes for box refinement (not used here).
            Some(d) => d.detect(0, frame)?,
            None => Vec::new(),
        };
        let s = match &mut self.net {
            Some(net) => self.follower.step_with_net(frame, &dets, net)?,
            None => self.follower.step(frame, &dets)?,
        };
        *busy += t.elapsed();
        Ok(s)
    }
}

/// Runs `shapetrack follow`.
pub fn run(args: Args) -> crate::CliResult {
    let files = image_files(&args.frames)?;
    if files.is_empty() {
        return Err(format!("--frames {}: no .jpg or .png frames", args.frames.display()).into());
    }
    if args.init_frame == 0 || args.init_frame > files.len() {
        return Err(FollowError::FrameOutOfRange {
            frame: args.init_frame,
            len: files.len(),
        }
        .into());
    }
    // Never over a file this run reads: a frame, the initial mask, the ground truth.
    let gt_files = match &args.gt {
        Some(d) => image_files(d)?,
        None => Vec::new(),
    };
    crate::outputs::refuse_overwrite(
        "--out",
        &args.out,
        files
            .iter()
            .chain(&gt_files)
            .map(PathBuf::as_path)
            .chain([args.init.as_path()]),
    )?;
    let init = args.init_frame - 1;
    let first = read_rgb(&files[init])?;
    let (w, h) = first.dimensions();
    let mask = read_mask_png(&args.init, w, h)?;
    // Every input is read and checked before the follower runs and before --out is written:
    // a bad --gt found only after the output was replaced would cost the user that file.
    let truth = match &args.gt {
        Some(gt) => Some(read_truth(gt, files.len(), w, h)?),
        None => None,
    };
    let frame0 = frame_of(&first)?;
    let cfg = follow_config(args.config.as_deref())?;
    let net = shared_net(args.model.as_deref(), args.net_cache.clone(), "follow")?;

    let mut steps: Vec<Option<FollowStep>> = vec![None; files.len()];
    steps[init] = Some(FollowStep {
        mask: mask.clone(),
        confidence: 1.0,
        lost: false,
        stopped: false,
        inliers: 0,
        from_detection: false,
        from_learned: false,
    });
    let mut busy = Duration::ZERO;
    let forward: Vec<usize> = (init + 1..files.len()).collect();
    let backward: Vec<usize> = (0..init).rev().collect();
    for order in [forward, backward] {
        let mut travel = Travel::new(&frame0, &mask, args.detector, &cfg, net.clone())?;
        for i in order {
            if args.method == Method::Copy {
                steps[i] = steps[init].clone();
                continue;
            }
            if travel.follower.stopped() {
                break;
            }
            let img = read_rgb(&files[i])?;
            if img.dimensions() != (w, h) {
                return Err(format!(
                    "{}: {}x{}, but the frames are {w}x{h}",
                    files[i].display(),
                    img.width(),
                    img.height()
                )
                .into());
            }
            steps[i] = Some(travel.step(&frame_of(&img)?, &mut busy)?);
        }
    }

    let mut records = Vec::new();
    let (mut lost, mut written) = (0, 0);
    for (i, s) in steps.iter().enumerate() {
        let Some(s) = s else { continue };
        lost += usize::from(s.lost);
        if s.mask.is_empty() {
            continue;
        }
        written += 1;
        let mut r = Record::from_box(i as u32 + 1, 1, s.mask.bbox());
        r.class = 1;
        r.score = s.confidence;
        r.mask = Some(Rle::from_mask(&s.mask, w, h));
        records.push(r);
    }
    let j = truth
        .as_ref()
        .map(|t| score_j(t, &steps, args.verbose))
        .transpose()?;
    write_text(&args.out, &write_mots(&records))?;
    let followed = files.len() - 1;
    eprintln!(
        "followed {followed} frames from frame {}: {written} masks written, {lost} lost; \
         {:.1} frames/s (follower{}; decoding excluded)",
        args.init_frame,
        followed as f64 / busy.as_secs_f64().max(1e-9),
        if args.detector == DetectorKind::Auto {
            " + detector"
        } else {
            ""
        }
    );
    if let Some(j) = j {
        println!("J {j:.4}");
    }
    Ok(())
}

/// The ground-truth masks of `--gt`, one per frame (`frames` of them, each `w × h`).
fn read_truth(
    gt: &Path,
    frames: usize,
    w: u32,
    h: u32,
) -> Result<PngMaskSequence, Box<dyn std::error::Error>> {
    let seq = read_png_mask_dir(gt, EightBit::Binary { id: 1 })?;
    if seq.num_frames as usize != frames || (seq.width, seq.height) != (w, h) {
        return Err(format!(
            "--gt {}: {} masks of {}x{}, expected {frames} of {w}x{h}",
            gt.display(),
            seq.num_frames,
            seq.width,
            seq.height,
        )
        .into());
    }
    Ok(seq)
}

/// Mean mask IoU over frames against a folder of ground-truth PNG masks (a frame where both
/// are empty counts 1, as DAVIS scores it).
fn score_j(
    seq: &PngMaskSequence,
    steps: &[Option<FollowStep>],
    verbose: bool,
) -> Result<f64, Box<dyn std::error::Error>> {
    let mut sum = 0.0;
    for (i, s) in steps.iter().enumerate() {
        let truth = seq
            .records
            .iter()
            .filter(|r| r.frame as usize == i + 1)
            .find_map(Record::mask_bitmap)
            .unwrap_or_else(Mask::empty);
        let ours = s.as_ref().map_or_else(Mask::empty, |s| s.mask.clone());
        let iou = if truth.is_empty() && ours.is_empty() {
            1.0
        } else {
            truth.iou(&ours)
        };
        if verbose {
            if let Some(s) = s {
                println!(
                    "frame {:4}  iou {iou:.3}  conf {:.3}  lost {}  inliers {:3}  area {} / {}",
                    i + 1,
                    s.confidence,
                    u8::from(s.lost),
                    s.inliers,
                    s.mask.area(),
                    truth.area()
                );
            }
        }
        sum += iou;
    }
    Ok(sum / steps.len() as f64)
}

/// VOT protocols to run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum VotProtocol {
    /// VOT2020 anchors (multi-start).
    Anchor,
    /// VOT2016–2019 reset-based.
    Reset,
    /// Both.
    Both,
}

/// Arguments of `shapetrack vot`.
#[derive(clap::Args)]
pub struct VotArgs {
    /// VOT sequence folder: frames (.jpg/.png) and groundtruth.txt (anchor.value if present).
    #[arg(long)]
    seq: PathBuf,
    /// Output folder for the region files (`<seq>_<anchor:08>.txt`, `<seq>_001.txt`).
    #[arg(long)]
    out: PathBuf,
    /// Protocol(s).
    #[arg(long, value_enum, default_value = "both")]
    protocol: VotProtocol,
    /// Anchor spacing when the folder has no anchor.value.
    #[arg(long, default_value_t = 50)]
    anchor_spacing: usize,
    /// Sequence name in the file names (default: the folder's name).
    #[arg(long)]
    sequence: Option<String>,
    /// The learned segmentation's model file, or `none` for the follower without it.
    #[arg(long)]
    model: Option<String>,
    /// Folder keeping the network's outputs between runs (evaluation only).
    #[arg(long)]
    net_cache: Option<PathBuf>,
    /// Follower settings as JSON (missing fields take their defaults), as `follow --config`.
    #[arg(long)]
    config: Option<String>,
}

/// The follower's settings from `--config` (JSON over the defaults), checked.
fn follow_config(json: Option<&str>) -> Result<FollowConfig, Box<dyn std::error::Error>> {
    let cfg: FollowConfig = match json {
        Some(j) => serde_json::from_str(j).map_err(|e| format!("--config: {e}"))?,
        None => FollowConfig::default(),
    };
    cfg.validate()?;
    Ok(cfg)
}

fn region_mask(r: &Region, w: u32, h: u32) -> Mask {
    match r {
        Region::Rectangle(b) => Mask::from_bbox(b).clipped(w, h).tight(),
        Region::Polygon(p) => rasterize_polygon(p, w, h),
        Region::Mask(m) => m.clipped(w, h).tight(),
        Region::Special(_) => Mask::empty(),
    }
}

/// What every run of one VOT sequence shares: its frame files, its ground truth and frame
/// size (the reset protocol's supervisor) and the learned segmentation's network.
struct VotSeq<'a> {
    files: &'a [PathBuf],
    gt: &'a [Region],
    size: (u32, u32),
    net: Option<&'a SharedNet>,
    cfg: &'a FollowConfig,
}

impl VotSeq<'_> {
    /// Frame `i`, decoded when a run reaches it: the sequence's frames are never all held
    /// (1,500 frames of 720p are 4 GB decoded), at the cost of decoding a frame once per run
    /// that passes it.
    fn frame(&self, i: usize) -> Result<RgbImage, Box<dyn std::error::Error>> {
        let img = read_rgb(&self.files[i])?;
        if img.dimensions() != self.size {
            return Err(format!("{}: frames differ in size", self.files[i].display()).into());
        }
        Ok(img)
    }
}

/// Follows from `start` through `order`, one region per frame. Under the reset protocol
/// (`until_stop`) it stops early once the follower stops or loses all overlap with the
/// ground truth; otherwise it fills the rest with empty masks.
fn follow_run(
    seq: &VotSeq<'_>,
    start: usize,
    init: &Region,
    order: impl Iterator<Item = usize>,
    until_stop: bool,
    stats: &mut (Duration, usize),
) -> Result<Vec<Region>, Box<dyn std::error::Error>> {
    let net = seq.net;
    let supervisor = until_stop.then_some((seq.gt, seq.size));
    let (w, h) = seq.size;
    let mask = region_mask(init, w, h);
    let mut out = Vec::new();
    let first = seq.frame(start)?;
    let Ok(mut f) = Follower::new(&frame_of(&first)?, &mask, seq.cfg.clone()) else {
        // An empty or off-frame gt region: nothing to follow.
        out.extend(order.map(|_| Region::Mask(Mask::empty())));
        return Ok(out);
    };
    for i in order {
        if f.stopped() {
            if until_stop {
                break;
            }
            out.push(Region::Mask(Mask::empty()));
            continue;
        }
        let img = seq.frame(i)?;
        let t = Instant::now();
        let frame = frame_of(&img)?;
        let s = match net {
            Some(n) => f.step_with_net(&frame, &[], &mut n.clone())?,
            None => f.step(&frame, &[])?,
        };
        stats.0 += t.elapsed();
        stats.1 += 1;
        let r = Region::Mask(s.mask);
        // Under the reset protocol the run ends at the first frame without overlap: the
        // supervisor re-initialises there, so following on would be wasted work. A frame
        // where the object is absent is no failure (`run_reset_protocol`'s rule).
        let failed = supervisor.is_some_and(|(gt, b)| {
            !gt[i].is_empty() && overlap(&r, &gt[i], Some(b), OverlapMethod::Toolkit) <= 0.0
        });
        out.push(r);
        if failed {
            break;
        }
    }
    Ok(out)
}

/// Runs `shapetrack vot`.
pub fn run_vot(args: VotArgs) -> crate::CliResult {
    let gt = read_regions(&args.seq.join("groundtruth.txt"))?;
    let files = image_files(&args.seq)?;
    if files.is_empty() || gt.len() != files.len() {
        return Err(format!(
            "{}: {} frames but {} ground-truth lines",
            args.seq.display(),
            files.len(),
            gt.len()
        )
        .into());
    }
    // Sizes from the headers only (the frames are decoded as the runs reach them).
    let sizes = files
        .iter()
        .map(|p| image::image_dimensions(p).map_err(|e| format!("{}: {e}", p.display())))
        .collect::<Result<Vec<_>, _>>()?;
    let (w, h) = sizes[0];
    if sizes.iter().any(|&d| d != (w, h)) {
        return Err("frames differ in size".into());
    }
    let seq = args.sequence.clone().unwrap_or_else(|| {
        args.seq
            .canonicalize()
            .ok()
            .and_then(|d| d.file_name().map(|n| n.to_string_lossy().into_owned()))
            .unwrap_or_else(|| "sequence".into())
    });
    // The name becomes part of each result file's name in --out: a path there
    // (`../../x`) would write outside it.
    let plain = std::path::Path::new(&seq)
        .file_name()
        .is_some_and(|n| n == std::ffi::OsStr::new(&seq));
    if !plain || seq == ".." {
        return Err(format!(
            "--sequence {seq:?}: a name, not a path (result files are written in --out)"
        )
        .into());
    }
    let cfg = follow_config(args.config.as_deref())?;
    std::fs::create_dir_all(&args.out)?;
    let net = shared_net(args.model.as_deref(), args.net_cache.clone(), "vot")?;
    let n = files.len();
    let stats = RefCell::new((Duration::ZERO, 0usize));
    let err: RefCell<Option<String>> = RefCell::new(None);
    let vot_seq = VotSeq {
        files: &files,
        gt: &gt,
        size: (w, h),
        net: net.as_ref(),
        cfg: &cfg,
    };
    let run = |start: usize, init: &Region, order: Box<dyn Iterator<Item = usize>>, stop| {
        follow_run(&vot_seq, start, init, order, stop, &mut stats.borrow_mut()).unwrap_or_else(
            |e| {
                err.borrow_mut().get_or_insert(e.to_string());
                Vec::new()
            },
        )
    };
    let mut results: Vec<(PathBuf, String)> = Vec::new();
    if matches!(args.protocol, VotProtocol::Anchor | VotProtocol::Both) {
        let af = args.seq.join("anchor.value");
        let anchors = if af.exists() {
            parse_anchor_values(&shapetrack::io::read_text(&af)?, &af.display().to_string())?
        } else {
            anchors_every(n, args.anchor_spacing)
        };
        let runs = run_anchor_protocol(n, &gt, &anchors, |start, init, dir| {
            let order: Box<dyn Iterator<Item = usize>> = match dir {
                Direction::Forward => Box::new(start + 1..n),
                Direction::Backward => Box::new((0..start).rev()),
            };
            run(start, init, order, false)
        })?;
        if let Some(e) = err.borrow().as_ref() {
            return Err(e.clone().into());
        }
        for (a, r) in anchors.iter().zip(&runs) {
            let p = args.out.join(format!("{seq}_{:08}.txt", a.frame));
            results.push((p, write_regions(r)));
        }
    }
    if matches!(args.protocol, VotProtocol::Reset | VotProtocol::Both) {
        // Failures are judged as `eval-vot` judges them (toolkit overlap, clipped to the image).
        let params = ResetParams {
            bounds: Some((w, h)),
            method: OverlapMethod::Toolkit,
            ..ResetParams::default()
        };
        let traj = run_reset_protocol(&gt, &params, |start, init| {
            run(start, init, Box::new(start + 1..n), true)
        });
        if let Some(e) = err.borrow().as_ref() {
            return Err(e.clone().into());
        }
        results.push((
            args.out.join(format!("{seq}_001.txt")),
            write_regions(&traj),
        ));
    }
    // Written only once both protocols ran: a frame found bad by the second must not leave
    // the first's files replaced and the second's old ones beside them.
    for (p, text) in &results {
        write_text(p, text)?;
    }
    let (busy, fr) = *stats.borrow();
    let peak =
        crate::outputs::peak_memory_kb().map_or(String::new(), |kb| format!(", peak_mem_kb={kb}"));
    eprintln!(
        "{fr} frames followed, {:.1} frames/s (follower only){peak}",
        fr as f64 / busy.as_secs_f64().max(1e-9)
    );
    Ok(())
}
