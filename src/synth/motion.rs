//! Motion from one frame to the next: the camera's pan ([`Camera`]) and every object's
//! acceleration, rotation, breathing and border policy.

use super::math::{below, sin_cos, uniform};
use super::object::Deform;
use super::{BorderPolicy, CameraConfig, Scene};

/// The camera of a scene with [`CameraConfig`]: the view's centre in world coordinates, its
/// pan velocity and acceleration, and its own random stream.
#[derive(Debug, Clone)]
pub(super) struct Camera {
    pub(super) cfg: CameraConfig,
    pub(super) centre: [f64; 2],
    pub(super) vel: [f64; 2],
    pub(super) acc: [f64; 2],
    pub(super) timer: u32,
    pub(super) rng: rand_xoshiro::Xoshiro256PlusPlus,
}

impl Camera {
    /// Image pixels per world pixel in frame `index` (1-based): a smooth oscillation through
    /// the zoom range.
    pub(super) fn zoom(&self, index: u32) -> f64 {
        let (lo, hi) = self.cfg.zoom_range;
        let t = (index - 1) as f64 / self.cfg.zoom_period;
        lo + (hi - lo) * (0.5 + 0.5 * sin_cos(std::f64::consts::TAU * t).0)
    }

    /// World coordinates of the view's top-left corner for a `w × h` image at `zoom`.
    pub(super) fn origin(&self, w: u32, h: u32, zoom: f64) -> [f64; 2] {
        [
            self.centre[0] - 0.5 * w as f64 / zoom,
            self.centre[1] - 0.5 * h as f64 / zoom,
        ]
    }

    /// One frame of panning, keeping the largest view inside the `world`.
    fn step(&mut self, world: (u32, u32), w: u32, h: u32) {
        if self.timer == 0 {
            let (s, c) = sin_cos(uniform(&mut self.rng, 0.0, std::f64::consts::TAU));
            let a = 0.15 * self.cfg.pan_speed * uniform(&mut self.rng, 0.0, 1.0);
            self.acc = [a * c, a * s];
            self.timer = below(&mut self.rng, 30, 90);
        }
        self.timer -= 1;
        let max = self.cfg.pan_speed;
        for i in 0..2 {
            self.vel[i] = (self.vel[i] + self.acc[i]).clamp(-max, max);
        }
        let min_zoom = self.cfg.zoom_range.0;
        let half = [0.5 * w as f64 / min_zoom, 0.5 * h as f64 / min_zoom];
        let size = [world.0 as f64, world.1 as f64];
        for i in 0..2 {
            self.centre[i] += self.vel[i];
            let (lo, hi) = (half[i], (size[i] - half[i]).max(half[i]));
            if (self.centre[i] < lo && self.vel[i] < 0.0)
                || (self.centre[i] > hi && self.vel[i] > 0.0)
            {
                self.vel[i] = -self.vel[i];
                self.acc[i] = -self.acc[i];
            }
            self.centre[i] = self.centre[i].clamp(lo, hi);
        }
    }
}

impl Scene {
    /// Advances every object by one frame and applies the border policy.
    pub(super) fn step(&mut self) {
        let (w, h) = (self.world.0 as f64, self.world.1 as f64);
        let m = self.cfg.motion.clone();
        if let Some(cam) = &mut self.camera {
            cam.step(self.world, self.cfg.width, self.cfg.height);
        }
        for o in &mut self.objects {
            o.age += 1;
            // Walkers keep their own pace; their size follows the perspective (`walk`).
            if !o.scripted && o.walker.is_none() {
                if o.accel_timer == 0 {
                    let (s, c) = sin_cos(uniform(&mut self.rng, 0.0, std::f64::consts::TAU));
                    let a = m.accel * uniform(&mut self.rng, 0.0, 1.0).sqrt();
                    o.acc = [a * c, a * s];
                    o.accel_timer = below(&mut self.rng, m.accel_period.0, m.accel_period.1 + 1);
                }
                o.accel_timer -= 1;
                o.vel[0] += o.acc[0];
                o.vel[1] += o.acc[1];
                let sp = (o.vel[0] * o.vel[0] + o.vel[1] * o.vel[1]).sqrt();
                if sp > m.speed.1 && sp > 0.0 {
                    o.vel = [o.vel[0] * m.speed.1 / sp, o.vel[1] * m.speed.1 / sp];
                } else if sp < m.speed.0 {
                    o.vel = if sp > 1e-9 {
                        [o.vel[0] * m.speed.0 / sp, o.vel[1] * m.speed.0 / sp]
                    } else {
                        [m.speed.0, 0.0]
                    };
                }
                o.scale += o.scale * o.dscale;
                if o.scale < m.scale_range.0 || o.scale > m.scale_range.1 {
                    o.scale = o.scale.clamp(m.scale_range.0, m.scale_range.1);
                    o.dscale = -o.dscale;
                }
            }
            o.pos[0] += o.vel[0];
            o.pos[1] += o.vel[1];
            o.angle += o.omega;
            if o.angle >= std::f64::consts::TAU || o.angle < 0.0 {
                o.angle = o.angle.rem_euclid(std::f64::consts::TAU);
            }
            let r = o.bound * o.scale * o.deform.as_ref().map_or(1.0, Deform::reach);
            match m.border {
                BorderPolicy::Bounce => {
                    for (axis, size) in [(0, w), (1, h)] {
                        if (o.pos[axis] - r < 0.0 && o.vel[axis] < 0.0)
                            || (o.pos[axis] + r > size && o.vel[axis] > 0.0)
                        {
                            o.vel[axis] = -o.vel[axis];
                            o.acc[axis] = -o.acc[axis];
                        }
                    }
                }
                BorderPolicy::Wrap => {
                    for (axis, size) in [(0, w), (1, h)] {
                        if o.pos[axis] + r < 0.0 {
                            o.pos[axis] += size + 2.0 * r;
                        } else if o.pos[axis] - r > size {
                            o.pos[axis] -= size + 2.0 * r;
                        }
                    }
                }
                BorderPolicy::Exit => {}
            }
            let inside =
                o.pos[0] + r > 0.0 && o.pos[0] - r < w && o.pos[1] + r > 0.0 && o.pos[1] - r < h;
            if inside {
                o.entered = true;
            }
        }
        if m.border == BorderPolicy::Exit {
            let before = self.objects.iter().filter(|o| !o.scripted).count();
            self.objects.retain(|o| {
                let r = o.bound * o.scale * o.deform.as_ref().map_or(1.0, Deform::reach);
                let inside = o.pos[0] + r > 0.0
                    && o.pos[0] - r < w
                    && o.pos[1] + r > 0.0
                    && o.pos[1] - r < h;
                // Objects that never made it in (an acceleration turned them away) give up
                // after a while rather than linger off-screen forever.
                inside || (!o.entered && o.age < 400)
            });
            let after = self.objects.iter().filter(|o| !o.scripted).count();
            for _ in after..before {
                let o = self.random_object(false);
                self.objects.push(o);
            }
        }
        self.walk();
    }
}
