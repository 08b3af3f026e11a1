//! One moving object: its model and state ([`Object`]), its non-rigid deformation
//! ([`Deform`]), and how a scene creates objects (scripted, random, entering through a border).

use super::math::{below, sin_cos, stream, uniform};
use super::{background, shape, DeformConfig, Scene, ScriptedShape, ShapeKind, DEFORM_STREAM};
use rand::Rng;

/// One object's model and state.
#[derive(Debug, Clone)]
pub(super) struct Object {
    pub(super) id: u64,
    pub(super) kind: ShapeKind,
    pub(super) poly: Vec<[f64; 2]>,
    pub(super) bound: f64,
    pub(super) texture: shape::Texture,
    pub(super) palette: Vec<[u8; 3]>,
    pub(super) pos: [f64; 2],
    pub(super) vel: [f64; 2],
    pub(super) acc: [f64; 2],
    pub(super) accel_timer: u32,
    pub(super) angle: f64,
    pub(super) omega: f64,
    pub(super) scale: f64,
    pub(super) dscale: f64,
    pub(super) z: f64,
    pub(super) scripted: bool,
    pub(super) entered: bool,
    pub(super) age: u32,
    /// This frame: clipped rectangle `[x0, x1) × [y0, y1)` of the spans drawn, if any.
    pub(super) drawn: Option<[i32; 4]>,
    /// This frame: full silhouette pixel count.
    pub(super) full_area: u64,
    /// Non-rigid deformation, when the scene deforms its objects.
    pub(super) deform: Option<Deform>,
    /// A pedestrian of a crowd scene: its size follows the perspective.
    pub(super) walker: Option<super::crowd::Walker>,
}

/// One object's deformation (see [`DeformConfig`]): its area pulsation and three radial
/// ripples, each `(amplitude, angular rate per frame, phase)`, the ripples with the cosine and
/// sine of their angular offset.
#[derive(Debug, Clone)]
pub(super) struct Deform {
    area: (f64, f64, f64),
    ripples: [(f64, f64, f64, f64, f64); 3],
}

impl Deform {
    fn draw(cfg: &DeformConfig, seed: u64, id: u64) -> Deform {
        let mut rng = stream(seed ^ id.wrapping_mul(0x9E6C_63D0_676A_9A99), DEFORM_STREAM);
        let rate = |rng: &mut rand_xoshiro::Xoshiro256PlusPlus| {
            std::f64::consts::TAU / uniform(rng, cfg.period.0, cfg.period.1)
        };
        let area = (
            uniform(&mut rng, 0.5 * cfg.area_amplitude, cfg.area_amplitude),
            rate(&mut rng),
            uniform(&mut rng, 0.0, std::f64::consts::TAU),
        );
        let mut ripples = [(0.0, 0.0, 0.0, 1.0, 0.0); 3];
        for r in &mut ripples {
            let amp = uniform(&mut rng, 0.3, 1.0) * cfg.outline_amplitude;
            let w = rate(&mut rng);
            let phase = uniform(&mut rng, 0.0, std::f64::consts::TAU);
            let (sp, cp) = sin_cos(uniform(&mut rng, 0.0, std::f64::consts::TAU));
            *r = (amp, w, phase, cp, sp);
        }
        Deform { area, ripples }
    }

    /// Area factor at frame age `t`.
    pub(super) fn area_factor(&self, t: f64) -> f64 {
        let (a, w, p) = self.area;
        1.0 + a * sin_cos(w * t + p).0
    }

    /// Radial factor at frame age `t` of the outline point in direction `(c, s)` (unit).
    pub(super) fn radial(&self, t: f64, c: f64, s: f64) -> f64 {
        // cos/sin of 2θ, 3θ, 4θ by complex multiplication: exact arithmetic, no trig.
        let (c2, s2) = (c * c - s * s, 2.0 * c * s);
        let (c3, s3) = (c2 * c - s2 * s, s2 * c + c2 * s);
        let (c4, s4) = (c2 * c2 - s2 * s2, 2.0 * c2 * s2);
        let mut f = 1.0;
        for (&(amp, w, p, cp, sp), (ck, sk)) in
            self.ripples.iter().zip([(c2, s2), (c3, s3), (c4, s4)])
        {
            f += amp * sin_cos(w * t + p).0 * (ck * cp - sk * sp);
        }
        f
    }

    /// How far beyond its rigid bound the object can reach.
    pub(super) fn reach(&self) -> f64 {
        (1.0 + self.area.0).sqrt() * (1.0 + self.ripples.iter().map(|r| r.0).sum::<f64>())
    }
}

impl Scene {
    pub(super) fn scripted_object(&mut self, s: &ScriptedShape) -> Object {
        let poly = shape::outline(s.kind, s.radius, s.aspect, &mut self.rng);
        self.make_object(
            s.kind,
            poly,
            [s.center.x, s.center.y],
            [s.velocity.x, s.velocity.y],
            s.angle,
            s.angular_velocity,
            s.z,
            true,
        )
    }

    #[allow(clippy::too_many_arguments)]
    pub(super) fn make_object(
        &mut self,
        kind: ShapeKind,
        poly: Vec<[f64; 2]>,
        pos: [f64; 2],
        vel: [f64; 2],
        angle: f64,
        omega: f64,
        z: f64,
        scripted: bool,
    ) -> Object {
        let bound = shape::bound(&poly);
        let palette = match self.cfg.appearance.similar_colours {
            Some(spread) => shape::palette_near(
                &mut self.rng,
                background::BG_LUMA,
                self.cfg.appearance.min_contrast,
                self.base_hue,
                spread,
            ),
            None => shape::palette(
                &mut self.rng,
                background::BG_LUMA,
                self.cfg.appearance.min_contrast,
            ),
        };
        let texture = shape::texture(&mut self.rng, bound, &palette);
        let id = self.next_id;
        self.next_id += 1;
        let deform = match (&self.cfg.motion.deform, scripted) {
            (Some(d), false) => Some(Deform::draw(d, self.cfg.seed, id)),
            _ => None,
        };
        // A deforming outline needs vertices to ripple: split long edges.
        let poly = if deform.is_some() {
            shape::subdivide(&poly, 0.15 * bound)
        } else {
            poly
        };
        let (w, h) = (self.world.0 as f64, self.world.1 as f64);
        let entered = pos[0] + bound > 0.0
            && pos[0] - bound < w
            && pos[1] + bound > 0.0
            && pos[1] - bound < h;
        Object {
            id,
            kind,
            poly,
            bound,
            texture,
            palette,
            pos,
            vel,
            acc: [0.0, 0.0],
            accel_timer: 0,
            angle,
            omega,
            scale: 1.0,
            dscale: 0.0,
            z,
            scripted,
            entered,
            age: 0,
            drawn: None,
            full_area: 0,
            deform,
            walker: None,
        }
    }

    /// A random object, placed inside the frame (`inside`) or just outside a border, heading in.
    pub(super) fn random_object(&mut self, inside: bool) -> Object {
        if let Some(c) = self.cfg.crowd {
            return self.random_walker(&c, inside);
        }
        let m = self.cfg.motion.clone();
        let rng = &mut self.rng;
        let kind = match &m.kinds {
            Some(k) => k[below(rng, 0, k.len() as u32) as usize],
            None => ShapeKind::ALL[below(rng, 0, ShapeKind::ALL.len() as u32) as usize],
        };
        let r = uniform(rng, m.radius.0, m.radius.1);
        let aspect = uniform(rng, 0.45, 0.85);
        let poly = shape::outline(kind, r, aspect, rng);
        let reach = shape::bound(&poly) * m.scale_range.1;
        let (w, h) = (self.world.0 as f64, self.world.1 as f64);
        let speed = uniform(rng, m.speed.0, m.speed.1);
        let spread = m.direction_spread.unwrap_or(std::f64::consts::PI);
        let leftward = rng.gen::<u32>() & 1 == 1;
        let mut dir = uniform(rng, -spread, spread);
        let pos;
        if inside {
            let px = if w > 2.0 * reach {
                uniform(rng, reach, w - reach)
            } else {
                w / 2.0
            };
            let py = if h > 2.0 * reach {
                uniform(rng, reach, h - reach)
            } else {
                h / 2.0
            };
            if leftward {
                dir += std::f64::consts::PI;
            }
            pos = [px, py];
        } else {
            // Enter through a side, heading inwards within ±60° (or the configured spread).
            let sides = if m
                .direction_spread
                .is_some_and(|s| s < std::f64::consts::FRAC_PI_4)
            {
                2
            } else {
                4
            };
            let side = below(rng, 0, sides);
            let spread = spread.min(1.05);
            dir = uniform(rng, -spread, spread);
            let along_x = uniform(rng, 0.0, w);
            let along_y = uniform(rng, 0.0, h);
            let out = reach + 1.0;
            pos = match side {
                0 => [-out, along_y],
                1 => {
                    dir += std::f64::consts::PI;
                    [w + out, along_y]
                }
                2 => {
                    dir += std::f64::consts::FRAC_PI_2;
                    [along_x, -out]
                }
                _ => {
                    dir -= std::f64::consts::FRAC_PI_2;
                    [along_x, h + out]
                }
            };
        }
        let mut pos = pos;
        if let Some(hs) = &m.headings {
            // Streams: a heading of the list, within the spread; objects entering come in
            // through the side the heading leaves from.
            let spread = m.direction_spread.unwrap_or(0.2);
            let hd = hs[below(rng, 0, hs.len() as u32) as usize];
            dir = hd + uniform(rng, -spread, spread);
            if !inside {
                let (sh, ch) = sin_cos(hd);
                let out = reach + 1.0;
                pos = if ch.abs() >= sh.abs() {
                    let y = uniform(rng, 0.0, h);
                    if ch > 0.0 {
                        [-out, y]
                    } else {
                        [w + out, y]
                    }
                } else {
                    let x = uniform(rng, 0.0, w);
                    if sh > 0.0 {
                        [x, -out]
                    } else {
                        [x, h + out]
                    }
                };
            }
        }
        let (s, c) = sin_cos(dir);
        let angle = uniform(rng, 0.0, std::f64::consts::TAU);
        let omega = uniform(rng, -m.max_rotation, m.max_rotation);
        let dscale = uniform(rng, -m.max_scale_rate, m.max_scale_rate);
        let z = uniform(rng, 0.0, 1.0);
        let mut o = self.make_object(
            kind,
            poly,
            pos,
            [speed * c, speed * s],
            angle,
            omega,
            z,
            false,
        );
        o.dscale = dscale;
        o
    }
}
