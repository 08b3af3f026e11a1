//! `shapetrack synth`: writes a deterministic synthetic sequence in MOTChallenge layout.
//!
//! ```text
//! DIR/seqinfo.ini          name, imDir=img1, frameRate, seqLength, imWidth, imHeight, imExt=.png
//! DIR/img1/000001.png ...  RGB8 frames
//! DIR/gt/gt.txt            frame,id,x,y,w,h,1,1,visibility,-1   (MOT16-style: consider, class)
//! DIR/gt/gt_mots.txt       frame id 1 height width rle           (MOTS txt; id = object id,
//!                                                                 class 1: not class*1000+id)
//! DIR/det/det.txt          frame,-1,x,y,w,h,score,-1,-1,-1       (tight boxes of the masks)
//! DIR/det/det_mots.txt     frame -1 -1 height width rle          (same detections, same order)
//! DIR/det/det_jitter.txt   frame,-1,x,y,w,h,score,-1,-1,-1       (box-only variant, jittered)
//! ```
//!
//! Detection files list one frame's detections in the same order, so line k of a frame in
//! `det_mots.txt` is the mask of line k of that frame in `det.txt` (which carries the score).

use clap::ValueEnum;
use image::codecs::png::{CompressionType, FilterType, PngEncoder};
use image::ImageEncoder;
use shapetrack::io::motchallenge::{write_mot, write_mots, SeqInfo};
use shapetrack::io::{write_text, IoError, Record};
use shapetrack::synth::{BorderPolicy, Family, Scene, ScenePreset as Preset, SynthConfig};
use std::path::{Path, PathBuf};

/// Border behaviour names for `--border`.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum Border {
    /// Bounce off the frame border.
    Bounce,
    /// Leave the frame; replaced by new objects.
    Exit,
    /// Wrap around to the opposite side.
    Wrap,
}

/// The files written, shown by `shapetrack synth --help`.
const LAYOUT: &str = "Writes DIR/seqinfo.ini, DIR/img1/000001.png..., \
DIR/gt/gt.txt (frame,id,x,y,w,h,1,1,visibility: MOT16-style, class 1), \
DIR/gt/gt_mots.txt (MOTS txt: frame id 1 height width rle, with id = object id, not class*1000+id), \
DIR/det/det.txt (frame,-1,x,y,w,h,score: tight boxes of the noisy masks), \
DIR/det/det_mots.txt (the same detections' masks, in the same order, id -1 class -1) and \
DIR/det/det_jitter.txt (box-only variant with jittered boxes). Frames and ids are 1-based.";

/// Arguments of `shapetrack synth`.
#[derive(clap::Args)]
#[command(after_help = LAYOUT)]
pub struct Args {
    /// Random seed: the same seed and flags give byte-identical output.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Number of frames [preset's; default 300].
    #[arg(long)]
    frames: Option<u32>,
    /// Number of random shapes alive at once [preset's; default 10].
    #[arg(long)]
    shapes: Option<u32>,
    /// Frame width in pixels [preset's; default 640].
    #[arg(long)]
    width: Option<u32>,
    /// Frame height in pixels [preset's; default 480].
    #[arg(long)]
    height: Option<u32>,
    /// Output folder (created; existing files are overwritten).
    #[arg(long)]
    out: PathBuf,
    /// Base configuration.
    #[arg(long, value_enum, default_value_t = Preset::Default)]
    preset: Preset,
    /// A scenario family instead of a preset: crossing, crowd, deform, occluders,
    /// enter-leave, camera, pedestrians (see `SynthConfig::family`).
    #[arg(long, conflicts_with = "preset")]
    family: Option<Family>,
    /// Frame rate written to seqinfo.ini [preset's; default 25].
    #[arg(long)]
    fps: Option<f64>,
    /// Probability that a visible object is not detected [preset's; default 0.05].
    #[arg(long)]
    miss_rate: Option<f64>,
    /// Mean number of false-positive blobs per frame [preset's; default 0.2].
    #[arg(long)]
    fp_rate: Option<f64>,
    /// Box jitter of det_jitter.txt, relative to box size [preset's; default 0.03].
    #[arg(long)]
    box_jitter: Option<f64>,
    /// Number of full-height occluding bars [preset's; default 1].
    #[arg(long)]
    bars: Option<u32>,
    /// Border behaviour [preset's; default exit].
    #[arg(long, value_enum)]
    border: Option<Border>,
    /// Sequence name in seqinfo.ini [default: the output folder's name].
    #[arg(long)]
    name: Option<String>,
}

impl Args {
    fn config(&self) -> SynthConfig {
        let mut c = match self.family {
            Some(f) => SynthConfig::family(f, self.seed),
            None => self.preset.config(self.seed),
        };
        c.seed = self.seed;
        c.frames = self.frames.unwrap_or(c.frames);
        c.shapes = self.shapes.unwrap_or(c.shapes);
        c.width = self.width.unwrap_or(c.width);
        c.height = self.height.unwrap_or(c.height);
        c.fps = self.fps.unwrap_or(c.fps);
        c.noise.miss_rate = self.miss_rate.unwrap_or(c.noise.miss_rate);
        c.noise.false_positives = self.fp_rate.unwrap_or(c.noise.false_positives);
        c.noise.box_jitter = self.box_jitter.unwrap_or(c.noise.box_jitter);
        c.occlusion.bars = self.bars.unwrap_or(c.occlusion.bars);
        if let Some(b) = self.border {
            c.motion.border = match b {
                Border::Bounce => BorderPolicy::Bounce,
                Border::Exit => BorderPolicy::Exit,
                Border::Wrap => BorderPolicy::Wrap,
            };
        }
        c
    }
}

fn mkdir(p: &Path) -> Result<(), IoError> {
    std::fs::create_dir_all(p).map_err(|source| IoError::Io {
        file: p.display().to_string(),
        source,
    })
}

fn write_png(path: &Path, rgb: &[u8], w: u32, h: u32) -> Result<(), IoError> {
    let io = |source| IoError::Io {
        file: path.display().to_string(),
        source,
    };
    let file = std::fs::File::create(path).map_err(io)?;
    let enc = PngEncoder::new_with_quality(
        std::io::BufWriter::new(file),
        CompressionType::Fast,
        FilterType::Adaptive,
    );
    enc.write_image(rgb, w, h, image::ExtendedColorType::Rgb8)
        .map_err(|e| IoError::Image {
            file: path.display().to_string(),
            message: e.to_string(),
        })
}

/// Runs the subcommand.
pub fn run(args: Args) -> crate::CliResult {
    let cfg = args.config();
    let scene = Scene::new(cfg.clone())?;
    let out = &args.out;
    let (img_dir, gt_dir, det_dir) = (out.join("img1"), out.join("gt"), out.join("det"));
    for d in [&img_dir, &gt_dir, &det_dir] {
        mkdir(d)?;
    }
    let name = args.name.clone().unwrap_or_else(|| {
        out.file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| "synth".into())
    });
    let info = SeqInfo {
        name,
        im_dir: "img1".into(),
        frame_rate: cfg.fps,
        seq_length: cfg.frames,
        im_width: cfg.width,
        im_height: cfg.height,
        im_ext: ".png".into(),
    };
    write_text(&out.join("seqinfo.ini"), &info.to_ini())?;
    let (mut gt, mut det, mut jit): (Vec<Record>, Vec<Record>, Vec<Record>) =
        (Vec::new(), Vec::new(), Vec::new());
    for f in scene {
        write_png(
            &img_dir.join(format!("{:06}.png", f.index)),
            &f.image,
            f.width,
            f.height,
        )?;
        gt.extend(f.gt_records());
        det.extend(f.detection_records());
        jit.extend(f.box_detection_records());
    }
    write_text(&gt_dir.join("gt.txt"), &write_mot(&gt))?;
    write_text(&gt_dir.join("gt_mots.txt"), &write_mots(&gt))?;
    write_text(&det_dir.join("det.txt"), &write_mot(&det))?;
    write_text(&det_dir.join("det_mots.txt"), &write_mots(&det))?;
    write_text(&det_dir.join("det_jitter.txt"), &write_mot(&jit))?;
    println!(
        "wrote {} frames ({}x{}), {} ground-truth boxes, {} detections to {}",
        cfg.frames,
        cfg.width,
        cfg.height,
        gt.len(),
        det.len(),
        out.display()
    );
    Ok(())
}
