//! The named scenes: the scenario families ([`Family`]), the presets the CLI and the browser
//! offer ([`ScenePreset`]) and the [`SynthConfig`] constructors behind them. Each is a fixed
//! test condition, so they are kept apart from the settings' definitions.

use super::{
    AppearanceConfig, BorderPolicy, CameraConfig, CrowdConfig, DeformConfig, MotionConfig,
    NoiseConfig, OccluderRect, OcclusionConfig, ShapeKind, SynthConfig,
};
use serde::{Deserialize, Serialize};

/// Walkers alive at once in the [`Family::Pedestrians`] scenes: about 46 of them in view a
/// frame, the density of the crowd issue 64 describes.
pub const PEDESTRIANS: u32 = 51;

/// Scenario families that stress a shape tracker, one stress each (see
/// [`SynthConfig::family`] for their settings).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Family {
    /// Four streams of shapes (right, down, left, up) crossing one another, entering and
    /// leaving: 10 shapes of radius 16–30 at 2.5–4.5 px/frame.
    Crossing,
    /// A dense crowd of look-alikes: 30 ellipses of radius 13–17 in colours of one hue band,
    /// bouncing at 1–3 px/frame, touching and overlapping often.
    Crowd,
    /// Non-rigid shapes: 8 discs, ellipses, irregular polygons and stars whose area pulsates
    /// by up to ±50 % (periods 30–90 frames) and whose outlines ripple (orders 2–4, up to 12 %
    /// of the radius), bouncing at 1.5–3.5 px/frame; no occluders.
    Deform,
    /// Occluders: 8 shapes crossing horizontally at 3–5 px/frame behind two full-height bars
    /// (sized for ~15-frame hides) and two free-standing rectangles.
    Occluders,
    /// Births and deaths: 10 fast shapes (3.5–6.5 px/frame) leaving through every border and
    /// replaced by new ones entering.
    EnterLeave,
    /// A moving camera: the view pans (up to 3 px/frame) and zooms (0.8–1.25×, period 150
    /// frames) over a world 1.6× the frame holding 10 shapes and a bar.
    Camera,
    /// A dense crowd from a fixed, raised camera, 1920×1080 at 25 fps, 200 frames: about 46
    /// pedestrians a frame (median visibility ~0.43) walking left and right along a walkway
    /// at their own pace, nearer people (lower feet) hiding farther ones for long stretches;
    /// amodal ground-truth boxes (hidden people included), visible-part masks and
    /// detections, misses rising as visibility falls. See [`SynthConfig::pedestrians`].
    Pedestrians,
}

impl Family {
    /// Every family.
    pub const ALL: [Family; 7] = [
        Family::Crossing,
        Family::Crowd,
        Family::Deform,
        Family::Occluders,
        Family::EnterLeave,
        Family::Camera,
        Family::Pedestrians,
    ];

    /// The family's name (`crossing`, `crowd`, `deform`, `occluders`, `enter-leave`, `camera`,
    /// `pedestrians`).
    pub fn name(self) -> &'static str {
        match self {
            Family::Crossing => "crossing",
            Family::Crowd => "crowd",
            Family::Deform => "deform",
            Family::Occluders => "occluders",
            Family::EnterLeave => "enter-leave",
            Family::Camera => "camera",
            Family::Pedestrians => "pedestrians",
        }
    }
}

impl std::str::FromStr for Family {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        Family::ALL
            .into_iter()
            .find(|f| f.name() == s)
            .ok_or_else(|| {
                let names: Vec<&str> = Family::ALL.iter().map(|f| f.name()).collect();
                format!("unknown scene family {s:?} (known: {})", names.join(", "))
            })
    }
}

/// The named scenes (the CLI's `synth --preset`, the browser's `new SynthScene(name)`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[cfg_attr(target_arch = "wasm32", derive(tsify::Tsify))]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "kebab-case")]
pub enum ScenePreset {
    /// [`SynthConfig::default`]: 640×480, 300 frames, 10 shapes leaving and entering, one
    /// occluding bar.
    #[default]
    Default,
    /// [`SynthConfig::occlusion_scene`]: 8 shapes crossing and bouncing behind two bars
    /// (~10-frame occlusions), 640×480.
    Occlusion,
    /// [`SynthConfig::demo`]: the 1280×720 browser demo, 600 frames, 12 shapes entering and
    /// leaving, two occluding bars.
    Demo,
}

impl ScenePreset {
    /// The scene's config; `seed` seeds the scenes that take one (the occlusion scene).
    pub fn config(self, seed: u64) -> SynthConfig {
        match self {
            ScenePreset::Default => SynthConfig::default(),
            ScenePreset::Occlusion => SynthConfig::occlusion_scene(seed),
            ScenePreset::Demo => SynthConfig::demo(),
        }
    }
}

impl SynthConfig {
    /// Crossings and occlusions: 8 shapes of radius 16–24 bounce around 640×480 moving within
    /// 20° of horizontal at 3–5 px/frame, so they cross one another and two full-height bars
    /// 80 px wide, sized to hide the mean object for 10 frames (seeds 1–3: 89 full occlusions
    /// of 4–19 frames, median 11, and objects crossing in ~20% of frames); 5% misses and the
    /// default noise otherwise. 300 frames.
    pub fn occlusion_scene(seed: u64) -> Self {
        Self {
            seed,
            shapes: 8,
            motion: MotionConfig {
                radius: (16.0, 24.0),
                speed: (3.0, 5.0),
                accel: 0.0,
                max_rotation: 0.02,
                max_scale_rate: 0.0,
                scale_range: (1.0, 1.0),
                direction_spread: Some(0.35),
                border: BorderPolicy::Bounce,
                ..MotionConfig::default()
            },
            occlusion: OcclusionConfig {
                bars: 2,
                bar_width: None,
                hidden_frames: 10.0,
                rects: Vec::new(),
            },
            ..Self::default()
        }
    }

    /// The browser demo's default: 1280×720, 600 frames, 12 larger shapes entering and leaving,
    /// two bars, a slight illumination drift and sensor noise. Seed 2024.
    pub fn demo() -> Self {
        Self {
            seed: 2024,
            frames: 600,
            shapes: 12,
            width: 1280,
            height: 720,
            motion: MotionConfig {
                radius: (24.0, 64.0),
                speed: (1.5, 6.0),
                ..MotionConfig::default()
            },
            occlusion: OcclusionConfig {
                bars: 2,
                ..OcclusionConfig::default()
            },
            appearance: AppearanceConfig {
                illumination_drift: 0.03,
                sensor_noise: 2,
                ..AppearanceConfig::default()
            },
            ..Self::default()
        }
    }

    /// The dense-crowd scene ([`Family::Pedestrians`]) with `people` walkers alive at once
    /// (entering ones included; about 0.91 of them are in view): 1920×1080, 25 fps, 200
    /// frames, no static occluders (people hide one another). The camera looks down on a
    /// walkway whose box centres span rows 0.40–0.73 of the frame; people are 180 px tall on
    /// its far edge and 400 px on its near one (±10 % stature), 0.36–0.46 as wide as tall,
    /// and walk left or right within 0.08 rad of horizontal at 0.47–1.0 body heights per
    /// second (about 0.8–1.7 m/s). Detections: 5 % random misses plus up to 85 % more as
    /// visibility falls below 0.7, masks of the visible pixels and their boxes, the default
    /// morphology, split and jitter noise, 0.5 false positives a frame. The walkway's width
    /// and the sizes were chosen so that, with [`PEDESTRIANS`] people, the median visibility
    /// is issue 64's 0.44 (measured: tests/data/quality/README.md).
    pub fn pedestrians(seed: u64, people: u32) -> Self {
        Self {
            seed,
            frames: 200,
            shapes: people,
            width: 1920,
            height: 1080,
            fps: 25.0,
            motion: MotionConfig {
                // Unused by walkers (sized by `crowd`); kept within the validated range.
                radius: (90.0, 220.0),
                speed: (0.0, 100.0),
                accel: 0.0,
                max_rotation: 0.0,
                max_scale_rate: 0.0,
                scale_range: (1.0, 1.0),
                kinds: Some(vec![ShapeKind::Ellipse]),
                border: BorderPolicy::Exit,
                ..MotionConfig::default()
            },
            occlusion: OcclusionConfig {
                bars: 0,
                ..OcclusionConfig::default()
            },
            noise: NoiseConfig {
                occlusion_miss: 0.85,
                false_positives: 0.5,
                ..NoiseConfig::default()
            },
            crowd: Some(CrowdConfig {
                walkway: (0.40, 0.73),
                height: (180.0, 400.0),
                stature: (0.9, 1.1),
                width_ratio: (0.36, 0.46),
                speed: (0.47, 1.0),
                drift: 0.08,
            }),
            ..Self::default()
        }
    }

    /// A scene of the scenario family `family` (see [`Family`]): 640×480, 25 fps, 300 frames,
    /// the default detection noise; [`Family::Pedestrians`] is [`SynthConfig::pedestrians`]
    /// with [`PEDESTRIANS`] people.
    pub fn family(family: Family, seed: u64) -> Self {
        use std::f64::consts::{FRAC_PI_2, PI};
        let base = Self {
            seed,
            occlusion: OcclusionConfig {
                bars: 0,
                ..OcclusionConfig::default()
            },
            ..Self::default()
        };
        match family {
            Family::Pedestrians => Self::pedestrians(seed, PEDESTRIANS),
            Family::Crossing => Self {
                shapes: 10,
                motion: MotionConfig {
                    radius: (16.0, 30.0),
                    speed: (2.5, 4.5),
                    accel: 0.03,
                    headings: Some(vec![0.0, FRAC_PI_2, PI, -FRAC_PI_2]),
                    direction_spread: Some(0.15),
                    border: BorderPolicy::Exit,
                    ..MotionConfig::default()
                },
                ..base
            },
            Family::Crowd => Self {
                shapes: 30,
                motion: MotionConfig {
                    radius: (13.0, 17.0),
                    speed: (1.0, 3.0),
                    max_rotation: 0.02,
                    kinds: Some(vec![ShapeKind::Ellipse]),
                    border: BorderPolicy::Bounce,
                    ..MotionConfig::default()
                },
                appearance: AppearanceConfig {
                    similar_colours: Some(0.35),
                    ..AppearanceConfig::default()
                },
                ..base
            },
            Family::Deform => Self {
                shapes: 8,
                motion: MotionConfig {
                    radius: (22.0, 34.0),
                    speed: (1.5, 3.5),
                    kinds: Some(vec![
                        ShapeKind::Disc,
                        ShapeKind::Ellipse,
                        ShapeKind::Irregular,
                        ShapeKind::Star,
                    ]),
                    scale_range: (1.0, 1.0),
                    max_scale_rate: 0.0,
                    deform: Some(DeformConfig {
                        area_amplitude: 0.5,
                        outline_amplitude: 0.12,
                        period: (30.0, 90.0),
                    }),
                    border: BorderPolicy::Bounce,
                    ..MotionConfig::default()
                },
                ..base
            },
            Family::Occluders => Self {
                shapes: 8,
                motion: MotionConfig {
                    radius: (16.0, 24.0),
                    speed: (3.0, 5.0),
                    accel: 0.0,
                    direction_spread: Some(0.35),
                    border: BorderPolicy::Bounce,
                    ..MotionConfig::default()
                },
                occlusion: OcclusionConfig {
                    bars: 2,
                    bar_width: None,
                    hidden_frames: 15.0,
                    rects: vec![
                        OccluderRect {
                            x: 250,
                            y: 40,
                            w: 130,
                            h: 110,
                        },
                        OccluderRect {
                            x: 400,
                            y: 330,
                            w: 150,
                            h: 110,
                        },
                    ],
                },
                ..base
            },
            Family::EnterLeave => Self {
                shapes: 10,
                motion: MotionConfig {
                    radius: (14.0, 30.0),
                    speed: (3.5, 6.5),
                    accel: 0.1,
                    border: BorderPolicy::Exit,
                    ..MotionConfig::default()
                },
                ..base
            },
            Family::Camera => Self {
                shapes: 10,
                motion: MotionConfig {
                    radius: (16.0, 30.0),
                    speed: (1.0, 3.0),
                    border: BorderPolicy::Bounce,
                    ..MotionConfig::default()
                },
                occlusion: OcclusionConfig {
                    bars: 1,
                    ..OcclusionConfig::default()
                },
                camera: Some(CameraConfig {
                    world_scale: 1.6,
                    pan_speed: 3.0,
                    zoom_range: (0.8, 1.25),
                    zoom_period: 150.0,
                }),
                ..base
            },
        }
    }
}
