//! The settings of a synthetic scene: [`SynthConfig`] and the parts it is made of (motion,
//! deformation, camera, occluders, appearance, detection noise, scripted objects). Only the
//! data and the plain transformations of it live here; the named scenes are in `presets`, the
//! range checks in `validate`.

use super::ShapeKind;
use crate::frame::{BBox, Point};
use serde::{Deserialize, Serialize};

/// What happens when an object reaches the frame border.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum BorderPolicy {
    /// Reflect the velocity when the object's bounding circle touches the border: objects stay
    /// fully inside the frame and keep their id for the whole sequence.
    Bounce,
    /// Objects leave through the border; once fully outside they are removed and (random ones)
    /// replaced by a new object, with a new id, entering through a random border. Ids are never
    /// reused.
    Exit,
    /// Objects leaving through one side come back through the opposite one, keeping their id
    /// (they have no ground truth while fully outside).
    Wrap,
}

/// How random objects look and move. Sizes are in pixels, rates per frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MotionConfig {
    /// Range of the outline radius (half the largest extent) at scale 1. Default `(14, 40)`.
    pub radius: (f64, f64),
    /// Range of the speed, pixels per frame. Default `(1.5, 5.0)`.
    pub speed: (f64, f64),
    /// Largest acceleration magnitude, pixels per frame². Default `0.12`.
    pub accel: f64,
    /// Frames between two acceleration changes, drawn in this range. Default `(20, 60)`.
    pub accel_period: (u32, u32),
    /// Largest angular speed, radians per frame. Default `0.04`.
    pub max_rotation: f64,
    /// Largest relative scale change per frame. Default `0.003`.
    pub max_scale_rate: f64,
    /// Scale limits (must contain 1; objects start at scale 1). Default `(0.8, 1.25)`.
    pub scale_range: (f64, f64),
    /// When set, initial and entering directions lie within this many radians of horizontal
    /// (left or right), which makes objects cross vertical occluders. Default `None` (any).
    pub direction_spread: Option<f64>,
    /// Border behaviour. Default [`BorderPolicy::Exit`].
    pub border: BorderPolicy,
    /// Outline families random objects are drawn from; `None`: every [`ShapeKind`].
    #[serde(default)]
    pub kinds: Option<Vec<ShapeKind>>,
    /// Headings (radians, 0 = rightwards, π/2 = downwards) random objects start and enter
    /// with, each within `direction_spread` (default 0.2) of one of these: streams that cross.
    /// `None`: any direction (or `direction_spread` around horizontal).
    #[serde(default)]
    pub headings: Option<Vec<f64>>,
    /// Non-rigid deformation of random objects; `None`: rigid shapes.
    #[serde(default)]
    pub deform: Option<DeformConfig>,
}

/// Non-rigid deformation: each random object's area pulsates and its outline ripples, both
/// smoothly and with its own seeded rates (drawn from a stream of their own, so turning
/// deformation on changes nothing else in the scene). The texture follows the pulsation; the
/// ripples move the outline over it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct DeformConfig {
    /// The area varies as `1 + a·sin(2πt/T + φ)` with `a` drawn in
    /// `[area_amplitude/2, area_amplitude]` per object: 0.5 is ±50 % (largest area 3× the
    /// smallest).
    pub area_amplitude: f64,
    /// Radial ripples of orders 2, 3 and 4, each of amplitude up to this fraction of the
    /// radius, every one with its own period and phase.
    pub outline_amplitude: f64,
    /// Range of the periods (frames) of the pulsation and the ripples.
    pub period: (f64, f64),
}

/// A camera moving over a world larger than the frame: the background, the occluders and the
/// objects live in world coordinates; each frame is the view through a camera that pans and
/// zooms smoothly (its motion drawn from a stream of its own). Ground truth and detections are
/// in image coordinates; objects enter and leave the view as it pans.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CameraConfig {
    /// The world is this many times the frame on each side (≥ 1).
    pub world_scale: f64,
    /// Largest pan speed, world pixels per frame.
    pub pan_speed: f64,
    /// Zoom range (image pixels per world pixel), e.g. `(0.8, 1.25)`; must contain values
    /// for which the view fits in the world.
    pub zoom_range: (f64, f64),
    /// Period (frames) of the zoom's oscillation through its range.
    pub zoom_period: f64,
}

impl Default for MotionConfig {
    fn default() -> Self {
        Self {
            radius: (14.0, 40.0),
            speed: (1.5, 5.0),
            accel: 0.12,
            accel_period: (20, 60),
            max_rotation: 0.04,
            max_scale_rate: 0.003,
            scale_range: (0.8, 1.25),
            direction_spread: None,
            border: BorderPolicy::Exit,
            kinds: None,
            headings: None,
            deform: None,
        }
    }
}

/// Pedestrians on a walkway seen from a fixed, raised camera: random objects become upright
/// walkers (a head on shoulders over a body, no rotation) whose feet lie on a band of the
/// image, whose height follows a linear perspective (smaller higher up, nearer the horizon),
/// who walk left or right at a constant speed drawn per person, and who are drawn in depth
/// order by the bottom of their box (the lower the feet, the nearer the camera, the later drawn: nearer people hide
/// farther ones). The ground truth of such a scene is also given as amodal boxes
/// ([`SynthFrame::amodal_gt_records`](super::SynthFrame::amodal_gt_records)): the whole body's
/// box, hidden or not, as the MOTChallenge pedestrian benchmarks annotate.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CrowdConfig {
    /// The walkway: the range of the box centres' rows, as fractions of the frame height
    /// (far edge, near edge).
    pub walkway: (f64, f64),
    /// A walker's height in pixels with its centre on the walkway's far edge and on its near
    /// edge (linear between them and beyond).
    pub height: (f64, f64),
    /// Each person's height relative to the perspective's, drawn in this range.
    pub stature: (f64, f64),
    /// Width over height, drawn per person in this range.
    pub width_ratio: (f64, f64),
    /// Walking speed in body heights per second, drawn per person (about 0.8–1.7 m/s for a
    /// 1.7 m person at `(0.47, 1.0)`); converted to pixels per frame with the scene's `fps`
    /// and the walker's height.
    pub speed: (f64, f64),
    /// Largest angle (radians) of a walking direction from horizontal.
    pub drift: f64,
}

impl CrowdConfig {
    /// A walker's height (pixels, before its stature) with its centre on row `y`: linear
    /// across the walkway, held at its edges' heights beyond them (a walker drifting off the
    /// walkway keeps a bounded size, and so a bounded texture).
    pub fn height_at(&self, y: f64, frame_height: f64) -> f64 {
        let (y0, y1) = (self.walkway.0 * frame_height, self.walkway.1 * frame_height);
        let t = if y1 > y0 {
            ((y - y0) / (y1 - y0)).clamp(0.0, 1.0)
        } else {
            0.5
        };
        (self.height.0 + t * (self.height.1 - self.height.0)).max(4.0)
    }

    /// The largest outline radius a walker can have (the tallest, widest one's box corner).
    pub fn max_reach(&self) -> f64 {
        let h = 0.5 * self.height.0.max(self.height.1) * self.stature.1;
        h * (1.0 + self.width_ratio.1 * self.width_ratio.1).sqrt()
    }
}

/// An axis-aligned occluder in whole pixels (drawn in front of every object).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct OccluderRect {
    /// Left column.
    pub x: u32,
    /// Top row.
    pub y: u32,
    /// Width in pixels.
    pub w: u32,
    /// Height in pixels.
    pub h: u32,
}

impl OccluderRect {
    /// The rectangle as a box.
    pub fn bbox(&self) -> BBox {
        BBox::new(self.x as f64, self.y as f64, self.w as f64, self.h as f64)
    }
}

/// Static occluders: vertical bars plus explicit rectangles.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct OcclusionConfig {
    /// Number of full-height vertical bars, spread evenly with a seeded jitter. Default `1`.
    pub bars: u32,
    /// Bar width in pixels; `None` sizes bars so that an object of mean radius at mean speed,
    /// crossing horizontally, is fully hidden for about `hidden_frames` frames:
    /// `2·mean radius + hidden_frames·mean speed`. Default `None`.
    pub bar_width: Option<u32>,
    /// Target full-occlusion length used when `bar_width` is `None`. Default `10`.
    pub hidden_frames: f64,
    /// Extra occluders at fixed places. Default none.
    pub rects: Vec<OccluderRect>,
}

impl Default for OcclusionConfig {
    fn default() -> Self {
        Self {
            bars: 1,
            bar_width: None,
            hidden_frames: 10.0,
            rects: Vec::new(),
        }
    }
}

/// Whole-image effects, and how far object colours keep from the background's grey level.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AppearanceConfig {
    /// Amplitude of a slow global gain `1 + a·sin(2π(t−1)/period)`. Default `0` (off).
    pub illumination_drift: f64,
    /// Period of the illumination drift, in frames. Default `250`.
    pub illumination_period: f64,
    /// Uniform per-channel sensor noise amplitude, grey levels. Default `0` (off).
    pub sensor_noise: u8,
    /// Least luma difference between any object colour and the background's nominal grey.
    /// Default `50`.
    pub min_contrast: f64,
    /// All objects' colours lie within this hue distance (on the 0–6 hue circle) of one
    /// scene-wide hue, with 2–3 colours each: look-alike objects. `None`: any colours.
    #[serde(default)]
    pub similar_colours: Option<f64>,
}

impl Default for AppearanceConfig {
    fn default() -> Self {
        Self {
            illumination_drift: 0.0,
            illumination_period: 250.0,
            sensor_noise: 0,
            min_contrast: 50.0,
            similar_colours: None,
        }
    }
}

/// The detection noise model (see the `noise` module docs for the exact process).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NoiseConfig {
    /// Probability that a visible object is not detected. Default `0.05`.
    pub miss_rate: f64,
    /// Mean number of false-positive blobs per frame (at most 16). Default `0.2`.
    pub false_positives: f64,
    /// Probability that a detected mask is eroded or dilated. Default `0.3`.
    pub morph_prob: f64,
    /// Largest erosion/dilation radius in pixels (1..=this, uniformly). Default `2`.
    pub morph_max: u32,
    /// Probability that a detected mask is split in two. Default `0.02`.
    pub split_prob: f64,
    /// Standard deviation of the box-only variant's jitter, relative to box size. Default `0.03`.
    pub box_jitter: f64,
    /// Objects (and split parts, false positives) with fewer visible pixels are never
    /// detected. Default `16`.
    pub min_area: u64,
    /// Extra miss probability of a barely visible object, falling linearly to 0 at 70 %
    /// visibility (a detector loses people half hidden in a crowd far more often than whole
    /// ones). Default `0`.
    #[serde(default)]
    pub occlusion_miss: f64,
}

impl Default for NoiseConfig {
    fn default() -> Self {
        Self {
            miss_rate: 0.05,
            false_positives: 0.2,
            morph_prob: 0.3,
            morph_max: 2,
            split_prob: 0.02,
            box_jitter: 0.03,
            min_area: 16,
            occlusion_miss: 0.0,
        }
    }
}

impl NoiseConfig {
    /// A detector that sees every object exactly: no misses, no false positives, exact masks.
    pub fn perfect() -> Self {
        Self {
            miss_rate: 0.0,
            false_positives: 0.0,
            morph_prob: 0.0,
            morph_max: 0,
            split_prob: 0.0,
            box_jitter: 0.0,
            min_area: 1,
            occlusion_miss: 0.0,
        }
    }
}

/// An object with a fully specified, constant-velocity trajectory (for tests that need to know
/// exactly where an object is).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ScriptedShape {
    /// Outline family.
    pub kind: ShapeKind,
    /// Outline radius (for rectangles, the half-width).
    pub radius: f64,
    /// Minor/major ratio for ellipses and rectangles (rectangle half-height = `radius·aspect`).
    pub aspect: f64,
    /// Centre in frame 1.
    pub center: Point,
    /// Displacement per frame.
    pub velocity: Point,
    /// Rotation in frame 1, radians.
    pub angle: f64,
    /// Rotation per frame, radians.
    pub angular_velocity: f64,
    /// Depth order: higher is nearer (random objects have `z` in `[0, 1)`).
    pub z: f64,
}

impl ScriptedShape {
    /// An axis-aligned, non-rotating rectangle of half-sizes `half_w × half_h` centred on
    /// `center` in frame 1, moving by `velocity` per frame, drawn in front of random objects.
    pub fn rectangle(center: Point, half_w: f64, half_h: f64, velocity: Point) -> Self {
        Self {
            kind: ShapeKind::Rectangle,
            radius: half_w,
            aspect: if half_w > 0.0 { half_h / half_w } else { 1.0 },
            center,
            velocity,
            angle: 0.0,
            angular_velocity: 0.0,
            z: 1.0,
        }
    }
}

/// Everything that defines a synthetic sequence. `Default` gives a 640×480, 25 fps, 300-frame
/// sequence of 10 shapes with one occluding bar and the default detection noise.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SynthConfig {
    /// Seed of every random choice. Default `0`.
    pub seed: u64,
    /// Number of frames. Default `300`.
    pub frames: u32,
    /// Number of random objects alive at once (with [`BorderPolicy::Exit`], replacements keep
    /// the count). Default `10`.
    pub shapes: u32,
    /// Frame width in pixels. Default `640`.
    pub width: u32,
    /// Frame height in pixels. Default `480`.
    pub height: u32,
    /// Frame rate (only written to `seqinfo.ini`; motion is per frame). Default `25`.
    pub fps: f64,
    /// How random objects move.
    pub motion: MotionConfig,
    /// Static occluders.
    pub occlusion: OcclusionConfig,
    /// Whole-image effects.
    pub appearance: AppearanceConfig,
    /// Detection noise.
    pub noise: NoiseConfig,
    /// Objects with exact trajectories, added to the random ones. Default none.
    pub scripted: Vec<ScriptedShape>,
    /// A panning and zooming camera; `None`: a static camera whose view is the world.
    #[serde(default)]
    pub camera: Option<CameraConfig>,
    /// Random objects are pedestrians on a walkway ([`CrowdConfig`]); `None`: shapes moving
    /// as `motion` says.
    #[serde(default)]
    pub crowd: Option<CrowdConfig>,
}

impl Default for SynthConfig {
    fn default() -> Self {
        Self {
            seed: 0,
            frames: 300,
            shapes: 10,
            width: 640,
            height: 480,
            fps: 25.0,
            motion: MotionConfig::default(),
            occlusion: OcclusionConfig::default(),
            appearance: AppearanceConfig::default(),
            noise: NoiseConfig::default(),
            scripted: Vec::new(),
            camera: None,
            crowd: None,
        }
    }
}

impl SynthConfig {
    /// The default scene with another seed.
    pub fn with_seed(seed: u64) -> Self {
        Self {
            seed,
            ..Self::default()
        }
    }

    /// The same scene at another frame size, for speed measurements at a chosen resolution
    /// (the app's bench page): shape radii, speeds and bar widths are scaled by
    /// √(new area / old area), fixed occluder rectangles by the width and height ratios, so
    /// the scene keeps its look, its object count and its occlusions and only the pixel count
    /// changes. Scripted trajectories and the camera path are left in their pixels (the
    /// presets have none). The size is checked when the scene is built ([`Scene::new`](super::Scene::new)).
    pub fn scaled_to(mut self, width: u32, height: u32) -> Self {
        let (sx, sy) = (
            width as f64 / self.width.max(1) as f64,
            height as f64 / self.height.max(1) as f64,
        );
        let s = (sx * sy).sqrt();
        let m = &mut self.motion;
        m.radius = (m.radius.0 * s, m.radius.1 * s);
        m.speed = (m.speed.0 * s, m.speed.1 * s);
        let o = &mut self.occlusion;
        o.bar_width = o.bar_width.map(|w| ((w as f64 * s).round() as u32).max(1));
        for r in &mut o.rects {
            r.x = (r.x as f64 * sx).round() as u32;
            r.y = (r.y as f64 * sy).round() as u32;
            r.w = ((r.w as f64 * sx).round() as u32).max(1);
            r.h = ((r.h as f64 * sy).round() as u32).max(1);
        }
        self.width = width;
        self.height = height;
        self
    }

    /// The bar width the scene uses: `bar_width`, or the automatic size described there.
    pub fn effective_bar_width(&self) -> u32 {
        self.occlusion.bar_width.unwrap_or_else(|| {
            let m = &self.motion;
            let r = (m.radius.0 + m.radius.1) / 2.0;
            let v = (m.speed.0 + m.speed.1) / 2.0;
            (2.0 * r + self.occlusion.hidden_frames * v)
                .round()
                .max(1.0) as u32
        })
    }
}
