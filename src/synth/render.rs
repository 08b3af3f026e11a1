//! Drawing a frame: the objects over the (viewed) background, far to near, the ground truth
//! read back from the id buffer, then the whole-image effects (illumination drift, sensor
//! noise).

use super::math::{sin_cos, stream};
use super::output::visible_in;
use super::{GtObject, Scene, Silhouette, SENSOR_STREAM};
use crate::frame::{BBox, Mask};
use rand::Rng;

/// A byte under the illumination gain `g16` (16.16 fixed point), rounded, at most 255.
#[inline]
fn lit(p: u8, g16: u32) -> u8 {
    ((p as u32 * g16 + 32768) >> 16).min(255) as u8
}

impl Scene {
    /// Draws background and objects into a new image and fills the id buffer.
    pub(super) fn render(&mut self) -> Vec<u8> {
        let (w, h) = (self.cfg.width as i32, self.cfg.height as i32);
        // With a camera, the image starts as the view of the world background (nearest world
        // pixel of each image pixel's centre), and the occluder mask is viewed the same way.
        let view = self.camera.as_ref().map(|cam| {
            let zoom = cam.zoom(self.next_index);
            (cam.origin(self.cfg.width, self.cfg.height, zoom), zoom)
        });
        let mut img = match view {
            None => self.background.clone(),
            Some((org, zoom)) => {
                let (ww, wh) = (self.world.0 as usize, self.world.1 as usize);
                let mut img = vec![0u8; 3 * w as usize * h as usize];
                self.view_occ.resize(w as usize * h as usize, 0);
                let cols: Vec<usize> = (0..w)
                    .map(|x| {
                        ((org[0] + (x as f64 + 0.5) / zoom).floor().max(0.0) as usize).min(ww - 1)
                    })
                    .collect();
                for y in 0..h as usize {
                    let wy =
                        ((org[1] + (y as f64 + 0.5) / zoom).floor().max(0.0) as usize).min(wh - 1);
                    for (x, &wx) in cols.iter().enumerate() {
                        let (i, wi) = (y * w as usize + x, wy * ww + wx);
                        img[3 * i..3 * i + 3].copy_from_slice(&self.background[3 * wi..3 * wi + 3]);
                        self.view_occ[i] = self.occ[wi];
                    }
                }
                img
            }
        };
        self.ids.fill(0);
        self.order.clear();
        self.order.extend(0..self.objects.len());
        let objs = &self.objects;
        self.order.sort_by(|&a, &b| {
            objs[a]
                .z
                .total_cmp(&objs[b].z)
                .then(objs[a].id.cmp(&objs[b].id))
        });
        let Scene {
            objects,
            order,
            poly,
            raster,
            ids,
            occ,
            view_occ,
            ..
        } = self;
        let occ: &[u8] = if view.is_some() { view_occ } else { occ };
        for &k in order.iter() {
            let o = &mut objects[k];
            let (sn, cs) = sin_cos(o.angle);
            let mut sc = o.scale;
            let (mut cx, mut cy) = (o.pos[0], o.pos[1]);
            let t = o.age as f64;
            if let Some(d) = &o.deform {
                // The pulsation scales the area (and the texture with it).
                sc *= d.area_factor(t).sqrt();
            }
            if let Some((org, zoom)) = view {
                cx = (cx - org[0]) * zoom;
                cy = (cy - org[1]) * zoom;
                sc *= zoom;
            }
            poly.clear();
            let deform = o.deform.as_ref();
            poly.extend(o.poly.iter().map(|p| {
                // Ripples move each outline point along its direction from the centre.
                let f = match deform {
                    Some(d) => {
                        let r = (p[0] * p[0] + p[1] * p[1]).sqrt();
                        if r > 0.0 {
                            d.radial(t, p[0] / r, p[1] / r)
                        } else {
                            1.0
                        }
                    }
                    None => 1.0,
                };
                let (px, py) = (p[0] * f, p[1] * f);
                [cx + sc * (cs * px - sn * py), cy + sc * (sn * px + cs * py)]
            }));
            o.full_area = raster.area(poly);
            let slot = (k + 1) as u16;
            // Object coordinates of a pixel centre: the inverse rotation and scale; moving one
            // pixel right adds (cos, −sin)/scale.
            let (du, dv) = (cs / sc, -sn / sc);
            let tex = &o.texture;
            let texels = tex.bytes();
            let mut drawn: Option<[i32; 4]> = None;
            raster.spans(poly, 0..h, |y, xa, xb| {
                let (xa, xb) = (xa.max(0), xb.min(w));
                if xb <= xa {
                    return;
                }
                let dy = y as f64 + 0.5 - cy;
                let dx = xa as f64 + 0.5 - cx;
                let mut u = (dx * cs + dy * sn) / sc;
                let mut v = (dy * cs - dx * sn) / sc;
                let row = y as usize * w as usize;
                for i in row + xa as usize..row + xb as usize {
                    if occ[i] == 0 {
                        let t = tex.offset(u, v);
                        img[3 * i..3 * i + 3].copy_from_slice(&texels[t..t + 3]);
                        ids[i] = slot;
                    }
                    u += du;
                    v += dv;
                }
                drawn = Some(match drawn {
                    None => [xa, y, xb, y + 1],
                    Some(d) => [d[0].min(xa), d[1].min(y), d[2].max(xb), d[3].max(y + 1)],
                });
            });
            o.drawn = drawn;
        }
        img
    }

    /// Ground truth from the id buffer, by increasing id (the objects' order).
    pub(super) fn ground_truth(&self) -> Vec<GtObject> {
        let w = self.cfg.width as usize;
        let mut out = Vec::with_capacity(self.objects.len());
        for (k, o) in self.objects.iter().enumerate() {
            let Some([x0, y0, x1, y1]) = o.drawn else {
                continue;
            };
            let slot = (k + 1) as u16;
            let (mut tx0, mut ty0, mut tx1, mut ty1) = (i32::MAX, i32::MAX, i32::MIN, i32::MIN);
            for y in y0..y1 {
                let row = &self.ids[y as usize * w + x0 as usize..y as usize * w + x1 as usize];
                if let (Some(a), Some(b)) = (
                    row.iter().position(|&v| v == slot),
                    row.iter().rposition(|&v| v == slot),
                ) {
                    tx0 = tx0.min(x0 + a as i32);
                    tx1 = tx1.max(x0 + b as i32 + 1);
                    ty0 = ty0.min(y);
                    ty1 = ty1.max(y + 1);
                }
            }
            if tx0 >= tx1 {
                continue;
            }
            let (mw, mh) = ((tx1 - tx0) as usize, (ty1 - ty0) as usize);
            let mut data = Vec::with_capacity(mw * mh);
            for y in ty0..ty1 {
                let s = y as usize * w + tx0 as usize;
                data.extend(self.ids[s..s + mw].iter().map(|&v| (v == slot) as u8));
            }
            let Ok(mask) = Mask::new(tx0, ty0, mw as u32, mh as u32, data) else {
                continue;
            };
            let area = mask.area();
            out.push(GtObject {
                id: o.id,
                kind: o.kind,
                bbox: BBox::new(tx0 as f64, ty0 as f64, mw as f64, mh as f64),
                mask,
                visibility: area as f64 / o.full_area.max(area) as f64,
                full_area: o.full_area,
                palette: o.palette.clone(),
            });
        }
        out
    }

    /// The whole silhouette of every object drawn in this frame (by increasing id), with its
    /// visibility from `gt` (0 for an object no pixel of which is visible).
    pub(super) fn silhouettes(&self, gt: &[GtObject]) -> Vec<Silhouette> {
        self.objects
            .iter()
            .filter_map(|o| {
                let [x0, y0, x1, y1] = o.drawn?;
                let visibility = visible_in(gt, o.id).map_or(0.0, |g| g.visibility);
                Some(Silhouette {
                    id: o.id,
                    bbox: BBox::new(x0 as f64, y0 as f64, (x1 - x0) as f64, (y1 - y0) as f64),
                    visibility,
                })
            })
            .collect()
    }

    /// Illumination drift and sensor noise, applied after the ground truth is taken.
    pub(super) fn apply_appearance(&mut self, index: u32, img: &mut [u8]) {
        let a = &self.cfg.appearance;
        // Plain element-wise integer arithmetic over the whole image, written so that it
        // vectorises (a lookup table or a per-byte division would not), in one pass when both
        // apply: the gain, then the noise, byte by byte, as two passes would (they were four
        // fifths of the demo scene's 1280×720 frame).
        let gain = (a.illumination_drift > 0.0).then(|| {
            let t = (index - 1) as f64 / a.illumination_period;
            let gain = 1.0 + a.illumination_drift * sin_cos(std::f64::consts::TAU * t).0;
            (gain * 65536.0 + 0.5) as u32
        });
        if a.sensor_noise == 0 {
            if let Some(g16) = gain {
                img.iter_mut().for_each(|p| *p = lit(*p, g16));
            }
            return;
        }
        let amp = a.sensor_noise as i16;
        let span = 2 * amp as u16 + 1;
        let mut rng = stream(
            self.cfg.seed ^ (index as u64).wrapping_mul(0x2545_F491_4F6C_DD1D),
            SENSOR_STREAM,
        );
        // The noise bytes: one 64-bit draw per 8 bytes, little-endian, the last draw cut to
        // what is left.
        self.noise.resize(img.len(), 0);
        let mut chunks = self.noise.chunks_exact_mut(8);
        for chunk in &mut chunks {
            chunk.copy_from_slice(&rng.gen::<u64>().to_le_bytes());
        }
        let rest = chunks.into_remainder();
        if !rest.is_empty() {
            let bits = rng.gen::<u64>().to_le_bytes();
            rest.copy_from_slice(&bits[..rest.len()]);
        }
        // Multiply-shift maps a random byte onto 0..span without a division.
        let noisy =
            |v: u8, n: u8| (v as i16 + ((n as u16 * span) >> 8) as i16 - amp).clamp(0, 255) as u8;
        match gain {
            Some(g16) => img
                .iter_mut()
                .zip(&self.noise)
                .for_each(|(p, &n)| *p = noisy(lit(*p, g16), n)),
            None => img
                .iter_mut()
                .zip(&self.noise)
                .for_each(|(p, &n)| *p = noisy(*p, n)),
        }
    }
}
