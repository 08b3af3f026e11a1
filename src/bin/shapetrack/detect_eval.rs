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
//! - `refine`: [`refine_box`] from that oracle box;
//! - `background`, `moving`, `auto`: the detectors of `shapetrack detect`, no oracle.
//!
//! J rewards the best mask of a frame and ignores the others, so a detector that sprays masks
//! loses nothing by it: the row under each table's mean counts the masks per frame that lie
//! off the object (under a tenth of their pixels on the ground truth). DAVIS annotates one
//! object per sequence, so a few of those are other things that really move (riders beside
//! the annotated one, cars passing).
//!
//! Speed: frames per second of each detector's own work (decoding excluded), one thread.

use crate::detect::{Kind, Runner};
use shapetrack::detect::{refine_box, MovingCameraDetector, MovingConfig, RefineConfig};
use shapetrack::io::{image_files, read_rgb, IoError};
use shapetrack::{Frame, Mask};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The columns, in order.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Method {
    /// Filled oracle box.
    Box,
    /// Refinement of the oracle box.
    Refine,
    /// Static-camera background subtraction.
    Background,
    /// Camera-motion-compensated background subtraction + refinement.
    Moving,
    /// The `auto` choice without boxes.
    Auto,
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
}

fn name(m: Method) -> &'static str {
    match m {
        Method::Box => "box (oracle)",
        Method::Refine => "refine (oracle box)",
        Method::Background => "background",
        Method::Moving => "moving",
        Method::Auto => "auto",
    }
}

fn gt_mask(path: &Path) -> Result<Mask, Box<dyn std::error::Error>> {
    let img = image::open(path)
        .map_err(|e| IoError::Image {
            file: path.display().to_string(),
            message: e.to_string(),
        })?
        .to_luma8();
    let (w, h) = img.dimensions();
    let bits: Vec<u8> = img.as_raw().iter().map(|&v| (v > 127) as u8).collect();
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
        frames.push(read_rgb(f)?);
        gt.push(gt_mask(&g)?);
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

/// J of one method on one sequence, its time and its off-object masks.
fn score(
    seq: &Seq,
    m: Method,
    refine: &RefineConfig,
    moving: &MovingConfig,
) -> Result<Score, Box<dyn std::error::Error>> {
    let mut runner = match m {
        Method::Background => Some(Runner::new(Kind::Background, None)?),
        Method::Moving => Some(Runner::Moving(Box::new(MovingCameraDetector::new(
            moving.clone(),
        )?))),
        Method::Auto => Some(Runner::new(Kind::Auto, None)?),
        _ => None,
    };
    let (mut sum, mut n, mut secs, mut off) = (0.0, 0usize, 0.0, 0usize);
    for (i, (img, gt)) in seq.frames.iter().zip(&seq.gt).enumerate() {
        let (w, h) = img.dimensions();
        let frame = Frame::rgb(img.as_raw(), w, h)?;
        let t = Instant::now();
        let masks: Vec<Mask> = match (m, runner.as_mut()) {
            (Method::Box, _) => vec![Mask::from_bbox(&gt.bbox())],
            (Method::Refine, _) => refine_box(&frame, &gt.bbox(), refine)?
                .into_iter()
                .collect(),
            (_, Some(r)) => r
                .detect(i as u32 + 1, &frame)?
                .into_iter()
                .filter_map(|d| d.mask)
                .collect(),
            (_, None) => Vec::new(),
        };
        secs += t.elapsed().as_secs_f64();
        off += masks
            .iter()
            .filter(|d| (d.intersection(gt) as f64) < OFF_OBJECT * d.area() as f64)
            .count();
        if gt.is_empty() {
            continue;
        }
        let best = masks.iter().map(|d| d.iou(gt)).fold(0.0, f64::max);
        sum += best;
        n += 1;
    }
    let chose = runner.map(|r| r.name().to_string()).unwrap_or_default();
    Ok(Score {
        j: sum / n.max(1) as f64,
        secs,
        off: off as f64 / seq.frames.len().max(1) as f64,
        chose,
    })
}

pub fn run(args: Args) -> crate::CliResult {
    let refine: RefineConfig = match &args.refine {
        Some(j) => serde_json::from_str(j)?,
        None => RefineConfig::default(),
    };
    let moving: MovingConfig = match &args.moving {
        Some(j) => serde_json::from_str(j)?,
        None => MovingConfig::default(),
    };
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
                let sc = score(&seq, m, &refine, &moving)?;
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
    Ok(())
}
