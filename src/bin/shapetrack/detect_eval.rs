//! `shapetrack detect-eval`: mask quality (J) and speed of each detector on DAVIS-layout data.
//!
//! ```text
//! shapetrack detect-eval --davis ../shared/data/davis2016-moving --davis ../shared/data/davis-car-shadow
//! ```
//!
//! Every sequence under `DIR/DAVIS/JPEGImages/480p/` with its masks under
//! `DIR/DAVIS/Annotations/480p/` is run through each detector. Per sequence,
//! J = mean over frames of the IoU between the ground-truth mask and the best-matching detected
//! mask (0 where there is none); frames whose ground truth is empty are left out. Columns:
//!
//! - `box`: the filled ground-truth bounding box (the oracle box) as the mask;
//! - `refine`: that oracle box segmented by the learned model (the colour refinement where it
//!   finds nothing), as `shapetrack detect --detector refine`;
//! - `refine-colour`: [`refine_box`] from the oracle box (no model);
//! - `background`, `moving`, `auto`, `auto-motion`: the detectors of `shapetrack detect`, no
//!   oracle (`auto` with the learned model, `auto-motion` without);
//! - `whole`: the learned model's salient regions of the whole frame alone.
//!
//! `--step N` scores every Nth frame only (detectors still see every frame); `--net-cache DIR`
//! keeps the network's outputs so a grid over the settings after the network re-runs fast.
//!
//! J rewards the best mask of a frame and ignores the others, so a detector that sprays masks
//! loses nothing by it: the row under each table's mean counts the masks per frame that lie
//! off the object (under a tenth of their pixels on the ground truth). DAVIS annotates one
//! object per sequence, so a few of those are other things that really move (riders beside
//! the annotated one, cars passing).
//!
//! Speed: frames per second of each detector's own work (decoding excluded), one thread.

use crate::detect::{runner, Kind, ModelChoice, Runner};
use crate::netcache::{CachedNet, SharedNet};
use shapetrack::detect::{refine_box, MovingCameraDetector, MovingConfig, RefineConfig};
use shapetrack::io::{image_files, read_rgb, IoError};
use shapetrack::segment::{Job, SegmentConfig, WholeFrame};
use shapetrack::segment::{Learned, AUTO_WHOLE_FRAME};
use shapetrack::{Detection, Frame, Mask};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The columns, in order.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Method {
    /// Filled oracle box.
    Box,
    /// The learned model on the oracle box.
    Refine,
    /// Colour refinement of the oracle box (no model).
    RefineColour,
    /// Static-camera background subtraction.
    Background,
    /// Camera-motion-compensated background subtraction + refinement.
    Moving,
    /// The `auto` choice without boxes, with the learned model.
    Auto,
    /// The `auto` choice without the model.
    AutoMotion,
    /// The model's salient regions of the whole frame alone.
    Whole,
}

/// Arguments of `shapetrack detect-eval`.
#[derive(clap::Args)]
pub struct Args {
    /// DAVIS-layout folder (holds DAVIS/JPEGImages/480p and DAVIS/Annotations/480p); repeat
    /// for several.
    #[arg(long, required = true)]
    davis: Vec<PathBuf>,
    /// Methods, comma-separated.
    #[arg(
        long,
        value_enum,
        value_delimiter = ',',
        default_value = "box,refine,background,moving,auto"
    )]
    methods: Vec<Method>,
    /// Refinement settings as JSON over the defaults (e.g. `{"smoothness": 20}`), for
    /// experiments; the table records the defaults when absent.
    #[arg(long)]
    refine: Option<String>,
    /// Moving-camera detector settings as JSON over the defaults (e.g. `{"threshold": 24}`),
    /// for experiments; the `moving` column uses the defaults when absent.
    #[arg(long)]
    moving: Option<String>,
    /// Only these sequences (comma-separated names); all when absent.
    #[arg(long, value_delimiter = ',')]
    sequences: Vec<String>,
    /// Learned segmentation settings as JSON over the defaults (e.g. `{"margin": 0.5}`).
    #[arg(long)]
    segment: Option<String>,
    /// The model file, or `none` (the learned columns then fail).
    #[arg(long)]
    model: Option<String>,
    /// Folder keeping the network's outputs between runs (evaluation only).
    #[arg(long)]
    net_cache: Option<PathBuf>,
    /// Score every Nth frame (1: all).
    #[arg(long, default_value_t = 1)]
    step: usize,
    /// Also write per-frame IoUs as JSON lines (sequence, method, frame, iou) to this file.
    #[arg(long)]
    frames_out: Option<PathBuf>,
}

fn name(m: Method) -> &'static str {
    match m {
        Method::Box => "box (oracle)",
        Method::Refine => "refine (oracle box)",
        Method::RefineColour => "refine-colour (oracle box)",
        Method::Background => "background",
        Method::Moving => "moving",
        Method::Auto => "auto",
        Method::AutoMotion => "auto-motion",
        Method::Whole => "whole frame (model)",
    }
}

/// A ground-truth mask, which must be of its frame's `size`: scored against masks of another
/// size, every IoU would silently be measured on the wrong pixels.
fn gt_mask(path: &Path, size: (u32, u32)) -> Result<Mask, Box<dyn std::error::Error>> {
    let img = shapetrack::io::image_file::read_mask_image(path, Some(size))?;
    let (w, h) = img.dimensions();
    // Grey above half is object; in a paletted PNG, an index ≠ 0 (whatever its colour).
    let bits = img.object_bits(|i| {
        i.to_luma8()
            .as_raw()
            .iter()
            .map(|&v| (v > 127) as u8)
            .collect()
    });
    Ok(Mask::from_full(w, h, &bits)?)
}

/// One sequence's frames and ground truth.
struct Seq {
    name: String,
    frames: Vec<image::RgbImage>,
    gt: Vec<Mask>,
}

fn sequences(root: &Path, only: &[String]) -> Result<Vec<PathBuf>, Box<dyn std::error::Error>> {
    let dir = root.join("DAVIS/JPEGImages/480p");
    let rd = std::fs::read_dir(&dir).map_err(|source| IoError::Io {
        file: dir.display().to_string(),
        source,
    })?;
    let mut v: Vec<PathBuf> = rd
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_dir())
        .filter(|p| {
            only.is_empty()
                || p.file_name()
                    .is_some_and(|n| only.iter().any(|o| o.as_str() == n))
        })
        .collect();
    v.sort();
    Ok(v)
}

fn load(root: &Path, seq_dir: &Path) -> Result<Seq, Box<dyn std::error::Error>> {
    let name = seq_dir
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let files = image_files(seq_dir)?;
    let mut frames = Vec::new();
    let mut gt = Vec::new();
    for f in &files {
        let stem = f.file_stem().map(|s| s.to_string_lossy().into_owned());
        let g = root
            .join("DAVIS/Annotations/480p")
            .join(&name)
            .join(format!("{}.png", stem.unwrap_or_default()));
        let frame = read_rgb(f)?;
        gt.push(gt_mask(&g, frame.dimensions())?);
        frames.push(frame);
    }
    Ok(Seq { name, frames, gt })
}

/// What one method did on one sequence.
struct Score {
    /// Mean best IoU over the frames with a ground truth.
    j: f64,
    /// Seconds inside the detector.
    secs: f64,
    /// Masks per frame with under a tenth of their pixels on the ground truth.
    off: f64,
    /// The detector `auto` chose.
    chose: String,
}

/// Share of a mask's pixels on the ground truth under which it counts as off the object.
const OFF_OBJECT: f64 = 0.1;

/// What every score needs beside the sequence.
struct Ctx {
    refine: RefineConfig,
    moving: MovingConfig,
    seg: SegmentConfig,
    /// The same for the crop around a given box (the refinement: `segment::BOX_SIDE`).
    seg_boxes: SegmentConfig,
    net: Option<SharedNet>,
    step: usize,
}

impl Ctx {
    fn net(&self) -> Result<SharedNet, Box<dyn std::error::Error>> {
        self.net.clone().ok_or_else(|| {
            "this method needs the learned model (installed by `npm ci`; --model PATH)".into()
        })
    }

    fn learned(&self, whole: WholeFrame) -> Result<Learned, Box<dyn std::error::Error>> {
        Ok(Learned {
            net: Box::new(self.net()?),
            cfg: self.seg.clone(),
            whole,
        })
    }
}

/// J of one method on one sequence, its time and its off-object masks; `frames` collects
/// each scored frame's IoU.
fn score(
    seq: &Seq,
    m: Method,
    ctx: &Ctx,
    frames: &mut Vec<(usize, f64)>,
) -> Result<Score, Box<dyn std::error::Error>> {
    let mut runner = match m {
        Method::Background => Some(runner(Kind::Background, None)?),
        Method::Moving => Some(Runner::Moving(Box::new(MovingCameraDetector::new(
            ctx.moving.clone(),
        )?))),
        Method::AutoMotion => Some(runner(Kind::Auto, None)?),
        Method::Auto => Some(runner(Kind::Auto, None)?.learned(ctx.learned(AUTO_WHOLE_FRAME)?)),
        _ => None,
    };
    let mut net = match m {
        Method::Refine | Method::Whole => Some(ctx.net()?),
        _ => None,
    };
    let (mut sum, mut n, mut secs, mut off) = (0.0, 0usize, 0.0, 0usize);
    for (i, (img, gt)) in seq.frames.iter().zip(&seq.gt).enumerate() {
        let scored = i % ctx.step.max(1) == 0;
        // Detectors that learn from every frame see every frame; the others only the scored.
        if !scored && runner.is_none() {
            continue;
        }
        let (w, h) = img.dimensions();
        let frame = Frame::rgb(img.as_raw(), w, h)?;
        if !scored {
            if let Some(r) = runner.as_mut() {
                r.observe(i as u32 + 1, &frame)?;
            }
            continue;
        }
        let t = Instant::now();
        let masks: Vec<Mask> = match (m, runner.as_mut(), net.as_mut()) {
            (Method::Box, _, _) => vec![Mask::from_bbox(&gt.bbox())],
            (Method::RefineColour, _, _) => refine_box(&frame, &gt.bbox(), &ctx.refine)?
                .into_iter()
                .collect(),
            (Method::Refine, _, Some(net)) => {
                if gt.is_empty() {
                    Vec::new()
                } else {
                    let d = Detection::from_box(gt.bbox(), 1.0);
                    let mut job = Job::new(w, h, vec![d], WholeFrame::Off, &ctx.seg_boxes)?;
                    job.run(&frame, net)?;
                    let out = job.finish();
                    match out.detections.into_iter().next().and_then(|d| d.mask) {
                        Some(m) => vec![m],
                        None => refine_box(&frame, &gt.bbox(), &ctx.refine)?
                            .into_iter()
                            .collect(),
                    }
                }
            }
            (Method::Whole, _, Some(net)) => {
                let cfg = SegmentConfig {
                    max_crops: 0,
                    ..ctx.seg.clone()
                };
                let mut job = Job::new(w, h, Vec::new(), WholeFrame::Masks, &cfg)?;
                job.run(&frame, net)?;
                job.finish()
                    .detections
                    .into_iter()
                    .filter_map(|d| d.mask)
                    .collect()
            }
            (_, Some(r), _) => r
                .detect(i as u32 + 1, &frame)?
                .into_iter()
                .filter_map(|d| d.mask)
                .collect(),
            _ => Vec::new(),
        };
        secs += t.elapsed().as_secs_f64();
        if !scored {
            continue;
        }
        off += masks
            .iter()
            .filter(|d| (d.intersection(gt) as f64) < OFF_OBJECT * d.area() as f64)
            .count();
        if gt.is_empty() {
            continue;
        }
        let best = masks.iter().map(|d| d.iou(gt)).fold(0.0, f64::max);
        frames.push((i, best));
        sum += best;
        n += 1;
    }
    let chose = runner.map(|r| r.name().to_string()).unwrap_or_default();
    Ok(Score {
        j: sum / n.max(1) as f64,
        secs,
        off: off as f64 / seq.frames.len().div_ceil(ctx.step.max(1)).max(1) as f64,
        chose,
    })
}

pub fn run(args: Args) -> crate::CliResult {
    // Every file under a --davis folder may be read (frames, ground truth).
    if let Some(out) = &args.frames_out {
        crate::outputs::refuse_inside("--frames-out", out, &args.davis)?;
    }
    // A sequence asked for by name that no --davis folder holds is a typo, not an empty table.
    let mut found = std::collections::BTreeSet::new();
    for root in &args.davis {
        for dir in sequences(root, &args.sequences)? {
            found.extend(dir.file_name().map(|n| n.to_string_lossy().into_owned()));
        }
    }
    if let Some(missing) = args.sequences.iter().find(|s| !found.contains(s.as_str())) {
        return Err(format!(
            "--sequences {missing}: no such sequence in {} (under DAVIS/JPEGImages/480p)",
            args.davis
                .iter()
                .map(|d| d.display().to_string())
                .collect::<Vec<_>>()
                .join(", ")
        )
        .into());
    }
    let refine: RefineConfig = match &args.refine {
        Some(j) => serde_json::from_str(j)?,
        None => RefineConfig::default(),
    };
    let moving: MovingConfig = match &args.moving {
        Some(j) => serde_json::from_str(j)?,
        None => MovingConfig::default(),
    };
    let seg = crate::detect::segment_settings(args.segment.as_deref(), false)?;
    let seg_boxes = crate::detect::segment_settings(args.segment.as_deref(), true)?;
    let uses_model = args
        .methods
        .iter()
        .any(|m| matches!(m, Method::Refine | Method::Auto | Method::Whole));
    let net = if uses_model {
        match ModelChoice::from_flag(args.model.as_deref()).load("detect-eval")? {
            Some(n) => Some(SharedNet(std::rc::Rc::new(std::cell::RefCell::new(
                CachedNet::new(n, args.net_cache.clone())?,
            )))),
            None => None,
        }
    } else {
        None
    };
    let ctx = Ctx {
        refine,
        moving,
        seg,
        seg_boxes,
        net,
        step: args.step,
    };
    let mut frames_out = String::new();
    let header: Vec<&str> = args.methods.iter().map(|&m| name(m)).collect();
    let mut all_fps: Vec<(f64, usize)> = vec![(0.0, 0); args.methods.len()];
    for root in &args.davis {
        println!("\n{}\n", root.display());
        println!("| sequence | frames | {} |", header.join(" | "));
        println!("|---|---|{}", "---|".repeat(header.len()));
        let mut means = vec![0.0; args.methods.len()];
        let mut offs = vec![0.0; args.methods.len()];
        let mut count = 0usize;
        for dir in sequences(root, &args.sequences)? {
            let seq = load(root, &dir)?;
            let mut cells = Vec::new();
            for (k, &m) in args.methods.iter().enumerate() {
                let mut per_frame = Vec::new();
                let sc = score(&seq, m, &ctx, &mut per_frame)?;
                for (f, iou) in per_frame {
                    frames_out.push_str(&format!(
                        "{{\"sequence\":\"{}\",\"method\":\"{}\",\"frame\":{f},\"iou\":{iou:.6}}}\n",
                        seq.name,
                        name(m)
                    ));
                }
                means[k] += sc.j;
                offs[k] += sc.off;
                all_fps[k].0 += sc.secs;
                all_fps[k].1 += seq.frames.len();
                cells.push(if m == Method::Auto {
                    format!("{:.3} ({})", sc.j, sc.chose)
                } else {
                    format!("{:.3}", sc.j)
                });
            }
            count += 1;
            println!(
                "| {} | {} | {} |",
                seq.name,
                seq.frames.len(),
                cells.join(" | ")
            );
        }
        let cells: Vec<String> = means
            .iter()
            .map(|s| format!("**{:.3}**", s / count.max(1) as f64))
            .collect();
        println!("| mean of {count} | | {} |", cells.join(" | "));
        let cells: Vec<String> = offs
            .iter()
            .map(|s| format!("{:.2}", s / count.max(1) as f64))
            .collect();
        println!("| off-object masks per frame | | {} |", cells.join(" | "));
    }
    let cells: Vec<String> = all_fps
        .iter()
        .map(|&(s, n)| format!("{:.1}", n as f64 / s.max(1e-9)))
        .collect();
    println!("\nframes per second (detector only, native, one thread, all sequences above):\n");
    println!("| | {} |", header.join(" | "));
    println!("|---|{}", "---|".repeat(header.len()));
    println!("| fps | {} |", cells.join(" | "));
    if let Some(net) = &ctx.net {
        let n = net.0.borrow();
        println!(
            "\nnetwork runs: {} (cached outputs used: {})",
            n.misses, n.hits
        );
    }
    if let Some(p) = &args.frames_out {
        shapetrack::io::write_text(p, &frames_out)?;
    }
    Ok(())
}
