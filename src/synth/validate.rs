//! Checking a [`SynthConfig`] before a scene is built: every setting's range, and the limits
//! that keep a scene's memory bounded (in wasm32 an allocation failure aborts the page).

use super::SynthConfig;
use thiserror::Error;

/// Errors building a [`Scene`](super::Scene) from a [`SynthConfig`].
#[derive(Debug, Error, Clone, PartialEq)]
pub enum SynthError {
    /// The frame size is outside `16..=8192` on a side.
    #[error("frame size {width}x{height} is outside 16..=8192 per side")]
    InvalidSize {
        /// Requested width.
        width: u32,
        /// Requested height.
        height: u32,
    },
    /// A numeric setting is outside its allowed range (or not finite).
    #[error("{field} = {value} is outside [{min}, {max}]")]
    OutOfRange {
        /// The setting, as its path in the config.
        field: &'static str,
        /// The value given.
        value: f64,
        /// Smallest allowed value.
        min: f64,
        /// Largest allowed value.
        max: f64,
    },
    /// A `(low, high)` setting has `low > high`.
    #[error("{field} = ({lo}, {hi}) is an empty range")]
    EmptyRange {
        /// The setting.
        field: &'static str,
        /// Low end given.
        lo: f64,
        /// High end given.
        hi: f64,
    },
    /// The objects' textures would need more memory than the scene allows.
    #[error("textures of {shapes} shapes up to radius {radius} need {bytes} bytes, at most {max}")]
    TooLarge {
        /// Objects alive at once (random plus scripted).
        shapes: u64,
        /// Largest object radius (times aspect for scripted shapes).
        radius: f64,
        /// Estimated texture bytes.
        bytes: u64,
        /// The limit.
        max: u64,
    },
    /// More objects than a frame's id buffer can hold.
    #[error("{shapes} shapes requested, at most {max} are supported")]
    TooManyShapes {
        /// Objects requested (random plus scripted).
        shapes: u64,
        /// The limit.
        max: u64,
    },
}

/// Objects a frame can hold (the id buffer is 16-bit).
const MAX_SHAPES: u64 = 10_000;
/// Texture memory a scene may use.
const MAX_TEXTURE_BYTES: u64 = 256 << 20;

impl SynthConfig {
    /// Checks every setting; [`Scene::new`](super::Scene::new) calls it.
    pub fn validate(&self) -> Result<(), SynthError> {
        fn range(field: &'static str, v: f64, min: f64, max: f64) -> Result<(), SynthError> {
            if v.is_finite() && v >= min && v <= max {
                Ok(())
            } else {
                Err(SynthError::OutOfRange {
                    field,
                    value: v,
                    min,
                    max,
                })
            }
        }
        fn pair(field: &'static str, p: (f64, f64), min: f64, max: f64) -> Result<(), SynthError> {
            range(field, p.0, min, max)?;
            range(field, p.1, min, max)?;
            if p.0 > p.1 {
                return Err(SynthError::EmptyRange {
                    field,
                    lo: p.0,
                    hi: p.1,
                });
            }
            Ok(())
        }
        if !(16..=8192).contains(&self.width) || !(16..=8192).contains(&self.height) {
            return Err(SynthError::InvalidSize {
                width: self.width,
                height: self.height,
            });
        }
        let total = self.shapes as u64 + self.scripted.len() as u64;
        if total > MAX_SHAPES {
            return Err(SynthError::TooManyShapes {
                shapes: total,
                max: MAX_SHAPES,
            });
        }
        range("fps", self.fps, 1e-3, 1e4)?;
        // A sequence's frame numbers stop at the readers' cap: a longer scene writes frames
        // (and ground truth) that no command of this project reads back.
        range(
            "frames",
            f64::from(self.frames),
            1.0,
            f64::from(crate::io::limits::MAX_FRAME),
        )?;
        let m = &self.motion;
        pair("motion.radius", m.radius, 2.0, 500.0)?;
        pair("motion.speed", m.speed, 0.0, 1000.0)?;
        range("motion.accel", m.accel, 0.0, 100.0)?;
        let ap = (m.accel_period.0 as f64, m.accel_period.1 as f64);
        pair("motion.accel_period", ap, 1.0, 1e6)?;
        range("motion.max_rotation", m.max_rotation, 0.0, 3.2)?;
        range("motion.max_scale_rate", m.max_scale_rate, 0.0, 0.5)?;
        pair("motion.scale_range", m.scale_range, 0.1, 10.0)?;
        range("motion.scale_range.0", m.scale_range.0, 0.1, 1.0)?;
        range("motion.scale_range.1", m.scale_range.1, 1.0, 10.0)?;
        if let Some(s) = m.direction_spread {
            range("motion.direction_spread", s, 0.0, std::f64::consts::PI)?;
        }
        if let Some(k) = &m.kinds {
            range("motion.kinds.len", k.len() as f64, 1.0, 1e3)?;
        }
        if let Some(hs) = &m.headings {
            range("motion.headings.len", hs.len() as f64, 1.0, 1e3)?;
            for &h in hs {
                range("motion.headings", h, -100.0, 100.0)?;
            }
        }
        if let Some(d) = &m.deform {
            range("motion.deform.area_amplitude", d.area_amplitude, 0.0, 0.9)?;
            range(
                "motion.deform.outline_amplitude",
                d.outline_amplitude,
                0.0,
                0.5,
            )?;
            pair("motion.deform.period", d.period, 2.0, 1e6)?;
        }
        if let Some(c) = &self.camera {
            range("camera.world_scale", c.world_scale, 1.0, 8.0)?;
            range("camera.pan_speed", c.pan_speed, 0.0, 1000.0)?;
            pair("camera.zoom_range", c.zoom_range, 1.0 / c.world_scale, 10.0)?;
            range("camera.zoom_period", c.zoom_period, 2.0, 1e9)?;
            let world = |side: u32| side as f64 * c.world_scale;
            if world(self.width) * world(self.height) > 64.0 * 1024.0 * 1024.0 {
                return Err(SynthError::OutOfRange {
                    field: "camera.world_scale",
                    value: c.world_scale,
                    min: 1.0,
                    max: (64.0 * 1024.0 * 1024.0 / (self.width as f64 * self.height as f64)).sqrt(),
                });
            }
        }
        let o = &self.occlusion;
        range("occlusion.bars", o.bars as f64, 0.0, 100.0)?;
        range("occlusion.hidden_frames", o.hidden_frames, 0.0, 1e4)?;
        let a = &self.appearance;
        range(
            "appearance.illumination_drift",
            a.illumination_drift,
            0.0,
            0.5,
        )?;
        range(
            "appearance.illumination_period",
            a.illumination_period,
            1.0,
            1e9,
        )?;
        range("appearance.min_contrast", a.min_contrast, 0.0, 100.0)?;
        if let Some(c) = a.similar_colours {
            range("appearance.similar_colours", c, 0.0, 3.0)?;
        }
        let n = &self.noise;
        range("noise.miss_rate", n.miss_rate, 0.0, 1.0)?;
        range("noise.false_positives", n.false_positives, 0.0, 16.0)?;
        range("noise.morph_prob", n.morph_prob, 0.0, 1.0)?;
        range("noise.morph_max", n.morph_max as f64, 0.0, 10.0)?;
        range("noise.split_prob", n.split_prob, 0.0, 1.0)?;
        range("noise.box_jitter", n.box_jitter, 0.0, 1.0)?;
        range("noise.occlusion_miss", n.occlusion_miss, 0.0, 1.0)?;
        if let Some(c) = &self.crowd {
            pair("crowd.walkway", c.walkway, 0.0, 1.0)?;
            range("crowd.height.0", c.height.0, 4.0, 4000.0)?;
            range("crowd.height.1", c.height.1, 4.0, 4000.0)?;
            pair("crowd.stature", c.stature, 0.1, 10.0)?;
            pair("crowd.width_ratio", c.width_ratio, 0.05, 2.0)?;
            pair("crowd.speed", c.speed, 0.0, 100.0)?;
            range("crowd.drift", c.drift, 0.0, 1.5)?;
        }
        for s in &self.scripted {
            range("scripted.radius", s.radius, 1.0, 1000.0)?;
            range("scripted.aspect", s.aspect, 0.01, 10.0)?;
            range("scripted.center.x", s.center.x, -1e6, 1e6)?;
            range("scripted.center.y", s.center.y, -1e6, 1e6)?;
            range("scripted.velocity.x", s.velocity.x, -1e4, 1e4)?;
            range("scripted.velocity.y", s.velocity.y, -1e4, 1e4)?;
            range("scripted.angle", s.angle, -1e6, 1e6)?;
            range("scripted.angular_velocity", s.angular_velocity, -1e3, 1e3)?;
            range("scripted.z", s.z, -1e9, 1e9)?;
        }
        // Textures live in object space at scale 1, about (2·bound)² texels of 3 bytes each;
        // refuse configs whose live objects would need hundreds of megabytes (in wasm32 an
        // allocation failure aborts the page).
        let texture = |r: f64| {
            let side = 2.0 * (r * std::f64::consts::SQRT_2 + 3.0);
            (3.0 * side * side) as u64
        };
        // Walkers' outlines are sized by the crowd's perspective, not by `motion.radius`, and
        // their textures by their own outline's reach (`shape::texture`: side 2·(reach + 2)).
        let (mut radius, mut bytes) = match &self.crowd {
            Some(c) => {
                let side = 2.0 * (c.max_reach() + 3.0);
                (
                    c.max_reach(),
                    self.shapes as u64 * (3.0 * side * side) as u64,
                )
            }
            None => (m.radius.1, self.shapes as u64 * texture(m.radius.1)),
        };
        for s in &self.scripted {
            let r = s.radius * s.aspect.max(1.0);
            radius = radius.max(r);
            bytes += texture(r);
        }
        if bytes > MAX_TEXTURE_BYTES {
            return Err(SynthError::TooLarge {
                shapes: total,
                radius,
                bytes,
                max: MAX_TEXTURE_BYTES,
            });
        }
        Ok(())
    }
}
