//! Per-shape geometry (thesis ch. 3): Canny edges, outer contours, image moments, the Delaunay
//! mesh and its convex shell, GJK intersection tests and the broad phase.
//!
//! [`mask_geometry`] runs once per detection (the tracker caches the result on the track);
//! [`box_geometry`] is the box-only equivalent. All coordinates are `f64` image coordinates;
//! pixel `(x, y)` is represented by its centre `(x+0.5, y+0.5)`, as in [`Mask::centroid`].
//!
//! - [`edges`]: padded mask crops, Canny edge points, contours (`CHAIN_APPROX_SIMPLE`).
//! - [`moments`]: spatial and central moments, orientation, elongation.
//! - [`shell`]: [`ConvexShell`] (hull, translate, grow, contain, intersect) and the [`Mesh`].
//! - [`gjk`]: parry2d's GJK on prepared shells and the thesis' GJK (Algorithm 2).
//! - [`broad`]: sort-and-sweep over bounding boxes.

pub mod broad;
pub mod edges;
pub mod gjk;
pub mod moments;
pub mod shell;

use serde::{Deserialize, Serialize};
use thiserror::Error;

pub use broad::overlapping_box_pairs;
pub use edges::{approx_simple, MaskCrop, CROP_PAD};
pub use gjk::{intersects_thesis, PreparedShell};
pub use moments::Moments;
pub use shell::{ConvexShell, Mesh, CONTAINS_TOLERANCE, TOUCH_TOLERANCE};

use crate::frame::{BBox, Mask, Point};

/// Errors of the geometry layer.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum GeometryError {
    /// The mask has no foreground pixel.
    #[error("mask is empty")]
    EmptyMask,
    /// The mask's padded crop does not fit in memory addresses.
    #[error("mask {width}x{height} is too large to process")]
    MaskTooLarge {
        /// Mask bitmap width.
        width: u32,
        /// Mask bitmap height.
        height: u32,
    },
    /// A configuration value is out of range.
    #[error(
        "invalid geometry config: {field} = {} ({reason})",
        crate::settings::Short::of(.value)
    )]
    InvalidConfig {
        /// The offending field.
        field: &'static str,
        /// Its value.
        value: f64,
        /// What is wrong.
        reason: &'static str,
    },
    /// A box has a non-finite coordinate or a negative size.
    #[error("invalid box x={x} y={y} w={w} h={h}")]
    InvalidBox {
        /// Left.
        x: f64,
        /// Top.
        y: f64,
        /// Width.
        w: f64,
        /// Height.
        h: f64,
    },
    /// A point has a non-finite coordinate.
    #[error("non-finite point ({x}, {y})")]
    NonFinitePoint {
        /// Horizontal coordinate.
        x: f64,
        /// Vertical coordinate.
        y: f64,
    },
    /// spade rejected the triangulation's input.
    #[error("Delaunay triangulation failed: {reason}")]
    Triangulation {
        /// spade's error.
        reason: String,
    },
}

/// Settings of [`mask_geometry`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GeometryConfig {
    /// Canny hysteresis low threshold (gradient magnitude, `0..≈1140`).
    ///
    /// Masks are binary 0/255, so every gradient comes from the shape's boundary; after
    /// Canny's σ = 1.4 blur a straight step gives a Sobel magnitude of ~580 and a lone pixel
    /// ~60. Low thresholds keep the boundary of thin and one-pixel parts; the blur's far tails
    /// stay below them.
    pub canny_low: f32,
    /// Canny hysteresis high threshold (`≥ canny_low`).
    pub canny_high: f32,
    /// Most vertices put into the Delaunay mesh (hull vertices and the centroid always go in,
    /// so the mesh's boundary is exactly the shell; interior edge points are subsampled).
    pub max_mesh_points: usize,
}

impl Default for GeometryConfig {
    fn default() -> Self {
        Self {
            canny_low: 20.0,
            canny_high: 40.0,
            max_mesh_points: 128,
        }
    }
}

impl GeometryConfig {
    /// Checks every field's range.
    pub fn validate(&self) -> Result<(), GeometryError> {
        let bad = |field, value: f32, reason| {
            Err(GeometryError::InvalidConfig {
                field,
                value: value as f64,
                reason,
            })
        };
        if !(self.canny_low.is_finite() && self.canny_low >= 0.0) {
            return bad("canny_low", self.canny_low, "must be finite and >= 0");
        }
        if !(self.canny_high.is_finite() && self.canny_high >= self.canny_low) {
            return bad(
                "canny_high",
                self.canny_high,
                "must be finite and >= canny_low",
            );
        }
        Ok(())
    }
}

/// Everything the tracker needs about one shape's geometry, computed once per detection.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ShapeGeometry {
    /// Centroid from the image moments (eq. 10); the box centre for box-only detections.
    pub centroid: Point,
    /// Spatial and central moments.
    pub moments: Moments,
    /// Tight bounding box of the foreground pixels (the box itself in box mode).
    pub bbox: BBox,
    /// The largest outer contour, compressed like `CHAIN_APPROX_SIMPLE`, in border-following
    /// order (counter-clockwise on screen). The box's corners in box mode.
    pub contour: Vec<Point>,
    /// The outer contours of the other parts of a multi-part mask, largest first.
    pub parts: Vec<Vec<Point>>,
    /// Centres of the Canny edge pixels of the whole mask (all parts). The box's corners in
    /// box mode.
    pub edge_points: Vec<Point>,
    /// Convex shell: the hull of the edge points, all contours and the centroid.
    pub shell: ConvexShell,
    /// The Delaunay mesh whose outer boundary is `shell` (for drawing).
    pub mesh: Mesh,
}

/// The geometry of a mask detection (thesis Fig. 13/16): Canny edges, outer contours, moments,
/// convex shell and Delaunay mesh. Errors on an empty mask or an invalid config; one-pixel and
/// one-line masks give point and segment shells (a ring of Canny edges around them usually
/// makes the shell two-dimensional).
pub fn mask_geometry(mask: &Mask, cfg: &GeometryConfig) -> Result<ShapeGeometry, GeometryError> {
    cfg.validate()?;
    let moments = Moments::of_mask(mask).ok_or(GeometryError::EmptyMask)?;
    let crop = MaskCrop::new(mask, CROP_PAD)?;
    let edge_points = crop.canny_points(cfg.canny_low, cfg.canny_high);
    let mut contours = crop.outer_contours();
    let contour = if contours.is_empty() {
        Vec::new()
    } else {
        contours.remove(0)
    };
    let centroid = moments.centroid;

    // The thesis hulls the Canny edge vertices; adding the contour points (which lie on the
    // mask's boundary pixels) guarantees that the shell covers every foreground pixel centre
    // even where Canny misses a thin or one-pixel part.
    let mut all: Vec<Point> = Vec::with_capacity(edge_points.len() + contour.len() + 1);
    all.extend_from_slice(&edge_points);
    all.extend_from_slice(&contour);
    for p in &contours {
        all.extend_from_slice(p);
    }
    all.push(centroid);
    let shell = ConvexShell::from_points(&all)?;

    // Delaunay on hull vertices + centroid + a subsample of the edge points. The region
    // estimator uses only the shell, and the mesh is for display, so the interior points are
    // capped: a 256×256 mask has ~1000 edge pixels, and triangulating them all for every
    // detection of every frame would cost more than the rest of the geometry together.
    let mut mesh_pts: Vec<Point> = shell.vertices().to_vec();
    mesh_pts.push(centroid);
    let budget = cfg.max_mesh_points.saturating_sub(mesh_pts.len());
    if budget > 0 && !edge_points.is_empty() {
        let stride = edge_points.len().div_ceil(budget).max(1);
        mesh_pts.extend(edge_points.iter().step_by(stride).copied());
    }
    mesh_pts.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    mesh_pts.dedup();
    let mesh = Mesh::delaunay(&mesh_pts, Point::new(crop.x0 as f64, crop.y0 as f64))?;

    Ok(ShapeGeometry {
        centroid,
        moments,
        bbox: mask.bbox(),
        contour,
        parts: contours,
        edge_points,
        shell,
        mesh,
    })
}

/// The geometry of a box-only detection: the box's corners as contour, edge points and shell,
/// its centre as centroid, the moments of a uniformly filled box, and a four-triangle mesh
/// (corners + centre). Errors on a non-finite box or a negative size.
pub fn box_geometry(b: &BBox) -> Result<ShapeGeometry, GeometryError> {
    let shell = ConvexShell::from_bbox(b)?;
    let centroid = b.center();
    let mut mesh_pts = shell.vertices().to_vec();
    if shell.len() >= 3 {
        mesh_pts.push(centroid);
    }
    let mesh = Mesh::delaunay(&mesh_pts, Point::new(b.x, b.y))?;
    Ok(ShapeGeometry {
        centroid,
        moments: Moments::of_box(b),
        bbox: *b,
        contour: shell.vertices().to_vec(),
        parts: Vec::new(),
        edge_points: shell.vertices().to_vec(),
        shell,
        mesh,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn disc(cx: i32, cy: i32, r: f64) -> Mask {
        let n = (2.0 * r).ceil() as i32 + 3;
        let mut full = Vec::new();
        for y in 0..n {
            for x in 0..n {
                let (dx, dy) = (
                    x as f64 + 0.5 - n as f64 / 2.0,
                    y as f64 + 0.5 - n as f64 / 2.0,
                );
                full.push((dx.hypot(dy) <= r) as u8);
            }
        }
        Mask::new(cx - n / 2, cy - n / 2, n as u32, n as u32, full)
            .unwrap()
            .tight()
    }

    #[test]
    fn disc_geometry() {
        let m = disc(100, 80, 12.0);
        let g = mask_geometry(&m, &GeometryConfig::default()).unwrap();
        let c = g.centroid;
        assert!(
            (c.x - 100.0).abs() < 0.6 && (c.y - 80.0).abs() < 0.6,
            "{c:?}"
        );
        assert!(g.shell.len() >= 8);
        assert!(g.mesh.triangle_count() > 0);
        assert_eq!(g.mesh.outer_boundary(), g.shell);
        assert!(g.mesh.vertices.len() <= GeometryConfig::default().max_mesh_points + 1);
        for p in g.edge_points.iter().chain(&g.contour) {
            assert!(g.shell.contains(*p));
        }
    }

    #[test]
    fn degenerate_masks_do_not_panic() {
        let cfg = GeometryConfig::default();
        for m in [
            Mask::new(5, 5, 1, 1, vec![1]).unwrap(),
            Mask::new(5, 5, 7, 1, vec![1; 7]).unwrap(),
            Mask::new(5, 5, 1, 7, vec![1; 7]).unwrap(),
            Mask::new(-3, -4, 2, 2, vec![1, 0, 0, 1]).unwrap(),
        ] {
            let g = mask_geometry(&m, &cfg).unwrap();
            assert!(!g.shell.is_empty());
            for (x, y) in m.pixels() {
                assert!(g.shell.contains(Point::new(x as f64 + 0.5, y as f64 + 0.5)));
            }
        }
        assert_eq!(
            mask_geometry(&Mask::empty(), &cfg),
            Err(GeometryError::EmptyMask)
        );
        let bad = GeometryConfig {
            canny_low: 50.0,
            canny_high: 10.0,
            ..cfg
        };
        assert!(matches!(
            mask_geometry(&Mask::new(0, 0, 1, 1, vec![1]).unwrap(), &bad),
            Err(GeometryError::InvalidConfig {
                field: "canny_high",
                ..
            })
        ));
    }

    #[test]
    fn box_geometry_is_corners_and_centre() {
        let g = box_geometry(&BBox::new(10.0, 20.0, 30.0, 40.0)).unwrap();
        assert_eq!(g.centroid, Point::new(25.0, 40.0));
        assert_eq!(g.shell.len(), 4);
        assert_eq!(g.shell.aabb(), BBox::new(10.0, 20.0, 30.0, 40.0));
        assert_eq!(g.mesh.triangle_count(), 4);
        assert!(box_geometry(&BBox::new(f64::NAN, 0.0, 1.0, 1.0)).is_err());
        assert_eq!(
            box_geometry(&BBox::new(1.0, 1.0, 0.0, 0.0))
                .unwrap()
                .shell
                .len(),
            1
        );
        let flat = box_geometry(&BBox::new(1.0, 1.0, 0.0, 5.0)).unwrap();
        assert_eq!(flat.shell.len(), 2);
        assert_eq!(flat.mesh.triangle_count(), 0);
        assert!(box_geometry(&BBox::new(0.0, 0.0, -1.0, 1.0)).is_err());
    }
}
