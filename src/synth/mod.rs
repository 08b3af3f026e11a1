//! Deterministic synthetic scenes with exact ground truth and noisy detections.
//!
//! A [`Scene`] renders textured shapes (discs, ellipses, rectangles, triangles, stars, Ls,
//! irregular polygons) moving over a static textured background, behind static occluding bars,
//! and reports per frame the RGB image, the ground-truth instance masks of the **visible** pixels,
//! and the detections a noisy detector would give ([`NoiseConfig`]).
//!
//! # Determinism
//! Everything is a function of [`SynthConfig`] (including its `seed`): the same config gives
//! byte-identical images, ground truth and detections on every run and every target, native or
//! wasm32. Randomness comes from `rand_xoshiro` streams, one per purpose (layout, objects,
//! per-frame detection noise, sensor noise), so the detection noise settings never change the
//! images. Only IEEE-exact float operations are used; sines and cosines come from
//! `math::sin_cos`, not the platform's libm. No hash maps.
//!
//! # Geometry and drawing
//! Each object is a polygon in object space, rotated by `angle`, scaled by `scale` and placed at
//! its centre. A pixel belongs to an object when its centre is inside the transformed polygon
//! (even–odd rule, half-open edges). Objects are drawn from far to near (ascending `z`, then id),
//! so nearer objects hide farther ones; occluders are in front of every object. Ground-truth
//! masks are the pixels each object finally owns; `visibility` is that count over the object's
//! full silhouette (unclipped by the frame border and unoccluded). An object with no visible
//! pixel has no ground truth in that frame. Textures live in object space, so they rotate and
//! scale with the object; there is no anti-aliasing, so every ground-truth pixel has exactly a
//! palette colour of its object (before illumination drift or sensor noise, when enabled).
//!
//! # Motion
//! Random objects move with a velocity whose speed stays within `speed`, change it by a random
//! acceleration redrawn every `accel_period` frames, rotate at a constant rate and breathe in
//! scale within `scale_range`. At the frame border they follow [`BorderPolicy`]: bounce off it,
//! wrap around (same id), or leave and be replaced by a fresh object (new id) entering through
//! a border. Scripted objects ([`ScriptedShape`]) move at constant velocity and angular velocity
//! from a given start, so tests can compute their trajectory exactly; they follow the border
//! policy too but are never replaced.
//!
//! Frame `t` (1-based) shows the state after `t − 1` motion steps; a scripted object's centre in
//! frame `t` is `center + (t − 1)·velocity`.

mod background;
mod config;
mod crowd;
pub(crate) mod math;
mod motion;
pub(crate) mod noise;
mod object;
mod output;
mod presets;
// The follower fills warped outlines with the same scanline rule.
pub(crate) mod raster;
mod render;
mod shape;
mod stats;
mod validate;

pub use config::{
    AppearanceConfig, BorderPolicy, CameraConfig, CrowdConfig, DeformConfig, MotionConfig,
    NoiseConfig, OccluderRect, OcclusionConfig, ScriptedShape, SynthConfig,
};
pub use output::{GtObject, Silhouette, SynthFrame};
pub use presets::{Family, ScenePreset, PEDESTRIANS};
pub use shape::ShapeKind;
pub use stats::SceneStats;
pub use validate::SynthError;

use math::{stream, uniform};
use motion::Camera;
use object::Object;
use raster::Rasterizer;

/// Purposes of the scene-wide random streams.
const LAYOUT_STREAM: u64 = 0x6c61_796f;
const OBJECT_STREAM: u64 = 0x6f62_6a73;
const SENSOR_STREAM: u64 = 0x7365_6e73;
const DEFORM_STREAM: u64 = 0x6465_666f;
const CAMERA_STREAM: u64 = 0x6361_6d65;
const PALETTE_STREAM: u64 = 0x7061_6c65;

/// A synthetic sequence being generated frame by frame (also an [`Iterator`] of frames).
#[derive(Debug, Clone)]
pub struct Scene {
    cfg: SynthConfig,
    next_index: u32,
    next_id: u64,
    objects: Vec<Object>,
    background: Vec<u8>,
    occ: Vec<u8>,
    occluders: Vec<OccluderRect>,
    ids: Vec<u16>,
    poly: Vec<[f64; 2]>,
    order: Vec<usize>,
    /// Scratch for the sensor noise bytes.
    noise: Vec<u8>,
    raster: Rasterizer,
    rng: rand_xoshiro::Xoshiro256PlusPlus,
    /// The world's size: the frame's, or larger with a camera.
    world: (u32, u32),
    camera: Option<Camera>,
    /// With a camera: this frame's view of the occluder mask.
    view_occ: Vec<u8>,
    /// The scene-wide hue of look-alike objects ([`AppearanceConfig::similar_colours`]).
    base_hue: f64,
}

impl Scene {
    /// Validates `cfg`, renders the background and occluders and places the initial objects.
    pub fn new(cfg: SynthConfig) -> Result<Scene, SynthError> {
        cfg.validate()?;
        let world = match &cfg.camera {
            Some(c) => (
                (cfg.width as f64 * c.world_scale).round() as u32,
                (cfg.height as f64 * c.world_scale).round() as u32,
            ),
            None => (cfg.width, cfg.height),
        };
        let (w, h) = world;
        let camera = cfg.camera.map(|c| {
            let mut rng = stream(cfg.seed, CAMERA_STREAM);
            let centre = [
                uniform(&mut rng, 0.4, 0.6) * w as f64,
                uniform(&mut rng, 0.4, 0.6) * h as f64,
            ];
            Camera {
                cfg: c,
                centre,
                vel: [0.0, 0.0],
                acc: [0.0, 0.0],
                timer: 0,
                rng,
            }
        });
        let base_hue = uniform(&mut stream(cfg.seed, PALETTE_STREAM), 0.0, 6.0);
        let mut layout = stream(cfg.seed, LAYOUT_STREAM);
        let mut background = background::render(&mut layout, w, h);
        let occluders = background::occluders(
            &mut layout,
            w,
            h,
            cfg.occlusion.bars,
            cfg.effective_bar_width(),
            &cfg.occlusion.rects,
        );
        let mut occ = vec![0u8; w as usize * h as usize];
        background::draw_occluders(&mut layout, &mut background, &mut occ, w, h, &occluders);
        let mut scene = Scene {
            next_index: 1,
            next_id: 1,
            objects: Vec::new(),
            background,
            occ,
            occluders,
            ids: vec![0; cfg.width as usize * cfg.height as usize],
            poly: Vec::new(),
            order: Vec::new(),
            noise: Vec::new(),
            raster: Rasterizer::default(),
            rng: stream(cfg.seed, OBJECT_STREAM),
            world,
            camera,
            view_occ: Vec::new(),
            base_hue,
            cfg,
        };
        for i in 0..scene.cfg.scripted.len() {
            let s = scene.cfg.scripted[i].clone();
            let o = scene.scripted_object(&s);
            scene.objects.push(o);
        }
        for _ in 0..scene.cfg.shapes {
            let o = scene.random_object(true);
            scene.objects.push(o);
        }
        Ok(scene)
    }

    /// The configuration.
    pub fn config(&self) -> &SynthConfig {
        &self.cfg
    }

    /// The static background with the occluders drawn in (RGB8, no objects, no illumination
    /// drift or sensor noise): what a perfect background model converges to. With a
    /// [`CameraConfig`] it is the whole world ([`Scene::world_size`]), of which each frame
    /// shows a moving view.
    pub fn background(&self) -> &[u8] {
        &self.background
    }

    /// The world's size: the frame's, or larger with a [`CameraConfig`].
    pub fn world_size(&self) -> (u32, u32) {
        self.world
    }

    /// The static occluders (bars first, then the configured rectangles), in world
    /// coordinates (image coordinates without a camera).
    pub fn occluders(&self) -> &[OccluderRect] {
        &self.occluders
    }

    /// The number of the next frame [`Scene::frame`] returns (1-based).
    pub fn next_index(&self) -> u32 {
        self.next_index
    }

    /// Renders the next frame and advances the motion; `None` after `frames` frames.
    pub fn frame(&mut self) -> Option<SynthFrame> {
        if self.next_index > self.cfg.frames {
            return None;
        }
        let index = self.next_index;
        let mut image = self.render();
        let gt = self.ground_truth();
        let silhouettes = self.silhouettes(&gt);
        self.apply_appearance(index, &mut image);
        let noisy = noise::detect(
            &self.cfg.noise,
            self.cfg.seed,
            index,
            &gt,
            self.cfg.width,
            self.cfg.height,
            &mut self.raster,
        );
        self.step();
        self.next_index += 1;
        Some(SynthFrame {
            index,
            width: self.cfg.width,
            height: self.cfg.height,
            image,
            gt,
            silhouettes,
            detections: noisy.masks,
            detection_sources: noisy.sources,
            box_detections: noisy.boxes,
        })
    }
}

impl Iterator for Scene {
    type Item = SynthFrame;

    fn next(&mut self) -> Option<SynthFrame> {
        self.frame()
    }
}

#[cfg(test)]
mod tests;
