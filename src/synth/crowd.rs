//! Pedestrians on a walkway ([`CrowdConfig`]): spawning walkers with the perspective's size
//! and a walking speed, and keeping their size and depth order in step with where they are.

use super::math::{sin_cos, uniform};
use super::object::Object;
use super::{CrowdConfig, Scene, ShapeKind};
use rand::Rng;

/// A walker's outline in units of its half width (x) and half height (y), head up: a head
/// on square shoulders over a body as wide as them (87 % of its box). A person seen whole
/// fills most of its box, so the box-based occlusion of real crowds carries over.
const PERSON: [[f64; 2]; 10] = [
    [-0.3, -1.0],
    [0.3, -1.0],
    [0.38, -0.82],
    [0.45, -0.72],
    [1.0, -0.62],
    [1.0, 1.0],
    [-1.0, 1.0],
    [-1.0, -0.62],
    [-0.45, -0.72],
    [-0.38, -0.82],
];

/// What a walker keeps beyond an object's state.
#[derive(Debug, Clone, Copy)]
pub(super) struct Walker {
    /// Its height over the perspective's at its row.
    stature: f64,
    /// The height (pixels) its outline was built at, i.e. at scale 1.
    base: f64,
}

impl Scene {
    /// A walker placed on the walkway (`inside`) or just outside the left or right border,
    /// heading in; left and right walkers are equally likely, so the crowd crosses in both
    /// directions.
    pub(super) fn random_walker(&mut self, c: &CrowdConfig, inside: bool) -> Object {
        let (w, h) = (self.world.0 as f64, self.world.1 as f64);
        let fps = self.cfg.fps;
        let rng = &mut self.rng;
        let y = uniform(rng, c.walkway.0 * h, c.walkway.1 * h);
        let stature = uniform(rng, c.stature.0, c.stature.1);
        let height = c.height_at(y, h) * stature;
        let ratio = uniform(rng, c.width_ratio.0, c.width_ratio.1);
        let (hw, hh) = (0.5 * height * ratio, 0.5 * height);
        let poly: Vec<[f64; 2]> = PERSON.iter().map(|p| [p[0] * hw, p[1] * hh]).collect();
        let speed = uniform(rng, c.speed.0, c.speed.1) * height / fps;
        let leftward = rng.gen::<u32>() & 1 == 1;
        let drift = uniform(rng, -c.drift, c.drift);
        let out = 0.5 * height + 1.0;
        let x = if inside {
            uniform(rng, 0.0, w)
        } else if leftward {
            w + out
        } else {
            -out
        };
        let (s, co) = sin_cos(drift);
        let vx = if leftward { -speed * co } else { speed * co };
        let mut o = self.make_object(
            ShapeKind::Irregular,
            poly,
            [x, y],
            [vx, speed * s],
            0.0,
            0.0,
            y + 0.5 * height,
            false,
        );
        o.walker = Some(Walker {
            stature,
            base: height,
        });
        o
    }

    /// After a motion step: each walker's size from the row it reached, and its depth from
    /// the bottom of its box (lower feet = nearer the camera = drawn later).
    pub(super) fn walk(&mut self) {
        let Some(c) = self.cfg.crowd else {
            return;
        };
        let h = self.world.1 as f64;
        for o in &mut self.objects {
            if let Some(wk) = o.walker {
                let height = c.height_at(o.pos[1], h) * wk.stature;
                o.scale = height / wk.base;
                o.z = o.pos[1] + 0.5 * height;
            }
        }
    }
}
