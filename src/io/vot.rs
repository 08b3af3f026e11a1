//! VOT region files: `groundtruth.txt` and tracker result files, one region per line.
//!
//! A line is, as in the VOT toolkit's `parse_region`:
//!
//! - one number: a special code (in results `1` = initialisation, `2` = failure, `0` = frame
//!   skipped after a failure / unknown);
//! - four numbers `x,y,w,h`: an axis-aligned rectangle;
//! - an even number (≥ 6) of numbers `x1,y1,x2,y2,…`: a polygon (rotated boxes are 4 points);
//! - `m<x>,<y>,<w>,<h>,<runs…>` (VOT 2020 masks): a `w × h` bitmap placed at `(x, y)`, its
//!   row-major run lengths alternating background / foreground, starting with background;
//! - a rectangle or polygon with a `NaN` coordinate: the target is absent (code 0).
//!
//! Values are separated by commas (whitespace also accepted); CRLF and a trailing newline are
//! fine. `anchor.value` files (one number a line: > 0 forward anchor, < 0 backward) are read
//! by [`parse_anchor_values`].

use super::limits::{MAX_POLYGON_VERTICES, MAX_SELF_CROSSING_VERTICES, MAX_TOTAL_PIXELS};
use super::rle::{bitmap_runs, for_each_run_pixel, runs_extent};
use super::{IoError, Rle};
use crate::frame::{BBox, Mask, Point};
use std::fmt::Write as _;

/// Special code: frame with no information (skipped after a failure, or target absent).
pub const SPECIAL_UNKNOWN: i32 = 0;
/// Special code: the tracker was initialised in this frame.
pub const SPECIAL_INIT: i32 = 1;
/// Special code: the tracker failed in this frame (reset protocol).
pub const SPECIAL_FAILURE: i32 = 2;

/// A VOT region.
#[derive(Debug, Clone, PartialEq)]
pub enum Region {
    /// A special code ([`SPECIAL_UNKNOWN`], [`SPECIAL_INIT`], [`SPECIAL_FAILURE`], …).
    Special(i32),
    /// An axis-aligned rectangle.
    Rectangle(BBox),
    /// A polygon (a rotated box is a 4-point polygon).
    Polygon(Vec<Point>),
    /// A bitmap mask placed in the image.
    Mask(Mask),
}

impl Region {
    /// Whether the region covers no area (special codes, degenerate shapes, empty masks).
    pub fn is_empty(&self) -> bool {
        match self {
            Region::Special(_) => true,
            Region::Rectangle(b) => !(b.w > 0.0 && b.h > 0.0),
            Region::Polygon(p) => {
                let (x0, x1, y0, y1) = extent(p);
                !(x1 > x0 && y1 > y0)
            }
            Region::Mask(m) => m.is_empty(),
        }
    }

    /// The region's axis-aligned bounding box (zero box for special codes).
    pub fn bbox(&self) -> BBox {
        match self {
            Region::Special(_) => BBox::default(),
            Region::Rectangle(b) => *b,
            Region::Polygon(p) => {
                let (x0, x1, y0, y1) = extent(p);
                BBox::from_xyxy(x0, y0, x1, y1)
            }
            Region::Mask(m) => m.bbox(),
        }
    }

    /// The special code, when this is one.
    pub fn special(&self) -> Option<i32> {
        match self {
            Region::Special(c) => Some(*c),
            _ => None,
        }
    }

    /// A full-image mask region from a COCO RLE.
    pub fn from_rle(rle: &Rle) -> Region {
        Region::Mask(rle.to_mask())
    }
}

fn extent(p: &[Point]) -> (f64, f64, f64, f64) {
    p.iter().fold(
        (
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ),
        |(a, b, c, d), q| (a.min(q.x), b.max(q.x), c.min(q.y), d.max(q.y)),
    )
}

fn split_values(s: &str) -> Vec<&str> {
    if s.contains(',') {
        s.split(',').map(str::trim).collect()
    } else {
        s.split_whitespace().collect()
    }
}

/// Parses one region line. `file` and `line` are for errors.
pub fn parse_region(text: &str, file: &str, line: usize) -> Result<Region, IoError> {
    parse_region_counted(text, file, line, &mut 0)
}

/// [`parse_region`], adding the mask pixels it decodes to `decoded` and refusing to go past
/// [`MAX_TOTAL_PIXELS`] (a file of many huge masks).
fn parse_region_counted(
    text: &str,
    file: &str,
    line: usize,
    decoded: &mut u64,
) -> Result<Region, IoError> {
    let s = text.trim();
    if s.is_empty() {
        return Err(IoError::parse(file, line, 1, "a region", s));
    }
    if let Some(rest) = s.strip_prefix('m') {
        let vals = split_values(rest);
        let mut ints = Vec::with_capacity(vals.len());
        for (i, v) in vals.iter().enumerate() {
            let n: i64 = v
                .parse()
                .map_err(|_| IoError::parse(file, line, i + 1, "an integer (mask region)", v))?;
            ints.push(n);
        }
        if ints.len() < 5 {
            return Err(IoError::parse(
                file,
                line,
                ints.len() + 1,
                "mask `m<x>,<y>,<w>,<h>,<runs…>`",
                s,
            ));
        }
        let (x, y, w, h) = (ints[0], ints[1], ints[2], ints[3]);
        let coord = |v: i64, col: usize| {
            i32::try_from(v).map_err(|_| {
                IoError::parse(
                    file,
                    line,
                    col,
                    "a mask offset that fits i32",
                    &v.to_string(),
                )
            })
        };
        let (x, y) = (coord(x, 1)?, coord(y, 2)?);
        if !(0..=1 << 16).contains(&w) || !(0..=1 << 16).contains(&h) || w * h > 1 << 26 {
            return Err(IoError::parse(
                file,
                line,
                3,
                "mask size in 0..=65536 per side, ≤ 64 Mpx",
                s,
            ));
        }
        let total = w * h;
        // Check the runs, then find the foreground's rows and columns (row-major), so only
        // the foreground's box is allocated: `m0,0,8192,8192,0,1` is one pixel, not 64 MB.
        let mut p = 0i64;
        for (i, &r) in ints[4..].iter().enumerate() {
            if r < 0 || r > total - p {
                return Err(IoError::parse(
                    file,
                    line,
                    i + 5,
                    format!("runs that fit a {w}x{h} mask"),
                    &r.to_string(),
                ));
            }
            p += r;
        }
        let runs: Vec<u64> = ints[4..].iter().map(|&r| r as u64).collect();
        let Some((r0, c0, r1, c1)) = runs_extent(runs.iter().copied(), w as u64, total as u64)
        else {
            return Ok(Region::Mask(Mask::empty()));
        };
        let (r0, c0, r1, c1) = (r0 as i64, c0 as i64, r1 as i64, c1 as i64);
        let (bw, bh) = (c1 - c0 + 1, r1 - r0 + 1);
        *decoded += (bw * bh) as u64;
        if *decoded > MAX_TOTAL_PIXELS {
            return Err(IoError::parse(
                file,
                line,
                5,
                format!(
                    "masks of at most {MAX_TOTAL_PIXELS} pixels in one file (the readers' cap)"
                ),
                &format!("{bw}x{bh}"),
            ));
        }
        let mut data = vec![0u8; (bw * bh) as usize];
        for_each_run_pixel(&runs, w as u64, |row, col| {
            let (row, col) = (row as i64 - r0, col as i64 - c0);
            if let Some(v) = data.get_mut((row * bw + col) as usize) {
                *v = 1;
            }
        });
        let (x, y) = (x.saturating_add(c0 as i32), y.saturating_add(r0 as i32));
        let m = Mask::new(x, y, bw as u32, bh as u32, data).map_err(|e| IoError::Invalid {
            file: file.to_string(),
            line,
            message: e.to_string(),
        })?;
        return Ok(Region::Mask(m));
    }
    let vals = split_values(s);
    let mut nums = Vec::with_capacity(vals.len());
    for (i, v) in vals.iter().enumerate() {
        let n: f64 = v
            .parse()
            .map_err(|_| IoError::parse(file, line, i + 1, "a number", v))?;
        // Beyond ±1e9 px a coordinate is nonsense, and areas of such polygons overflow to
        // infinity (an accuracy of NaN); NaN itself is VOT's "target absent".
        if n.is_infinite() || n.abs() > 1e9 {
            return Err(IoError::parse(file, line, i + 1, "a number within ±1e9", v));
        }
        nums.push(n);
    }
    match nums.len() {
        1 => {
            let c = nums[0];
            if c.is_nan() || c.fract() != 0.0 || c.abs() > i32::MAX as f64 {
                return Err(IoError::parse(file, line, 1, "an integer special code", s));
            }
            Ok(Region::Special(c as i32))
        }
        _ if nums.iter().any(|v| v.is_nan()) && (nums.len() == 4 || nums.len() % 2 == 0) => {
            Ok(Region::Special(SPECIAL_UNKNOWN))
        }
        4 => Ok(Region::Rectangle(BBox::new(
            nums[0], nums[1], nums[2], nums[3],
        ))),
        n if n >= 6 && n % 2 == 0 => {
            let points: Vec<Point> = nums.chunks(2).map(|c| Point::new(c[0], c[1])).collect();
            check_polygon(&points, file, line, s)?;
            Ok(Region::Polygon(points))
        }
        n => Err(IoError::parse(
            file,
            line,
            n,
            "1 (special), 4 (rectangle) or an even number ≥ 6 (polygon) of values",
            s,
        )),
    }
}

/// Refuses a polygon whose exact overlap would cost more than the caps allow: more than
/// [`MAX_POLYGON_VERTICES`], or more than [`MAX_SELF_CROSSING_VERTICES`] and crossing itself
/// (the sweep's events grow with the crossings, the work with events × edges).
fn check_polygon(points: &[Point], file: &str, line: usize, s: &str) -> Result<(), IoError> {
    let n = points.len();
    if n > MAX_POLYGON_VERTICES {
        return Err(IoError::parse(
            file,
            line,
            2 * MAX_POLYGON_VERTICES + 1,
            format!("a polygon of at most {MAX_POLYGON_VERTICES} vertices (it has {n})"),
            s,
        ));
    }
    if n > MAX_SELF_CROSSING_VERTICES && crosses_itself(points) {
        return Err(IoError::parse(
            file,
            line,
            1,
            format!(
                "a polygon that does not cross itself (one of {n} vertices does; above \
                 {MAX_SELF_CROSSING_VERTICES} vertices polygons must be simple)"
            ),
            s,
        ));
    }
    Ok(())
}

/// Whether two non-adjacent edges of the closed polygon `p` cross properly (`O(n²)`, run only
/// on polygons above [`MAX_SELF_CROSSING_VERTICES`] and at most [`MAX_POLYGON_VERTICES`]).
fn crosses_itself(p: &[Point]) -> bool {
    let n = p.len();
    let orient = |a: Point, b: Point, c: Point| {
        let d = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
        if d > 0.0 {
            1
        } else if d < 0.0 {
            -1
        } else {
            0
        }
    };
    let edge = |i: usize| (p[i], p[(i + 1) % n]);
    for i in 0..n {
        let (a, b) = edge(i);
        for j in i + 2..n {
            if i == 0 && j == n - 1 {
                continue; // adjacent through the closing edge
            }
            let (c, d) = edge(j);
            let (o1, o2) = (orient(a, b, c), orient(a, b, d));
            let (o3, o4) = (orient(c, d, a), orient(c, d, b));
            if o1 * o2 < 0 && o3 * o4 < 0 {
                return true;
            }
        }
    }
    false
}

/// Parses a whole region file (one region a line; blank lines other than a trailing one are
/// errors, since every line is a frame).
pub fn parse_regions(text: &str, file: &str) -> Result<Vec<Region>, IoError> {
    region_lines(text, file).collect()
}

/// The regions of a region file's text, one a line, parsed as they are taken (what
/// [`parse_regions`] collects): a reader that scores each region and drops it holds one at a
/// time. The masks decoded still count towards [`MAX_TOTAL_PIXELS`] over the file.
pub fn region_lines<'a>(
    text: &'a str,
    file: &'a str,
) -> impl Iterator<Item = Result<Region, IoError>> + 'a {
    let body = text.strip_suffix('\n').unwrap_or(text);
    let body = body.strip_suffix('\r').unwrap_or(body);
    let mut decoded = 0u64;
    body.split('\n')
        .filter(move |_| !body.is_empty())
        .enumerate()
        .map(move |(i, l)| {
            parse_region_counted(l.trim_end_matches('\r'), file, i + 1, &mut decoded)
        })
}

/// Reads a region file from disk.
pub fn read_regions(path: &std::path::Path) -> Result<Vec<Region>, IoError> {
    parse_regions(&super::read_text(path)?, &path.display().to_string())
}

/// Formats one region as a VOT line (without the newline). Masks are written over their tight
/// box, as the toolkit does; an empty mask is `m0,0,0,0,0`.
pub fn format_region(r: &Region) -> String {
    let mut s = String::new();
    match r {
        Region::Special(c) => {
            let _ = write!(s, "{c}");
        }
        Region::Rectangle(b) => {
            let _ = write!(s, "{},{},{},{}", b.x, b.y, b.w, b.h);
        }
        Region::Polygon(p) => {
            let parts: Vec<String> = p.iter().map(|q| format!("{},{}", q.x, q.y)).collect();
            s.push_str(&parts.join(","));
        }
        Region::Mask(m) => {
            let m = m.tight();
            let _ = write!(s, "m{},{},{},{}", m.x(), m.y(), m.width(), m.height());
            for r in bitmap_runs(m.data()) {
                let _ = write!(s, ",{r}");
            }
        }
    }
    s
}

/// Formats regions as a VOT region file.
pub fn write_regions(regions: &[Region]) -> String {
    let mut s = String::new();
    for r in regions {
        s.push_str(&format_region(r));
        s.push('\n');
    }
    s
}

/// The direction a tracker runs from an anchor.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Direction {
    /// Towards the end of the sequence.
    Forward,
    /// Towards its first frame.
    Backward,
}

/// An anchor of the VOT2020 protocol: the tracker is initialised at `frame` (0-based) and run
/// in `direction` to the sequence's end (or start).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Anchor {
    /// 0-based frame index.
    pub frame: usize,
    /// Run direction.
    pub direction: Direction,
}

/// Parses an `anchor.value` file (one value per frame: > 0 forward anchor, < 0 backward, 0 or
/// empty none) into anchors ordered as the toolkit runs them: forward ones, then backward.
pub fn parse_anchor_values(text: &str, file: &str) -> Result<Vec<Anchor>, IoError> {
    let (mut fwd, mut bwd) = (Vec::new(), Vec::new());
    for (i, l) in text.lines().enumerate() {
        let l = l.trim();
        if l.is_empty() {
            continue;
        }
        let v: f64 = l
            .parse()
            .map_err(|_| IoError::parse(file, i + 1, 1, "a number", l))?;
        if v > 0.0 {
            fwd.push(Anchor {
                frame: i,
                direction: Direction::Forward,
            });
        } else if v < 0.0 {
            bwd.push(Anchor {
                frame: i,
                direction: Direction::Backward,
            });
        }
    }
    fwd.extend(bwd);
    Ok(fwd)
}

/// Writes anchors as an `anchor.value` file for a sequence of `num_frames` frames.
pub fn write_anchor_values(anchors: &[Anchor], num_frames: usize) -> String {
    let mut v = vec![0i8; num_frames];
    for a in anchors {
        if let Some(slot) = v.get_mut(a.frame) {
            *slot = match a.direction {
                Direction::Forward => 1,
                Direction::Backward => -1,
            };
        }
    }
    v.iter().map(|x| format!("{x}\n")).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_every_kind() {
        let text = "1\n10,20,30,40\n1,2,3,4,5,6,7,8\nm2,3,3,2,1,4,1\nnan,nan,nan,nan\r\n2\n";
        let r = parse_regions(text, "t").unwrap();
        assert_eq!(r[0], Region::Special(1));
        assert_eq!(r[1], Region::Rectangle(BBox::new(10.0, 20.0, 30.0, 40.0)));
        assert_eq!(
            r[2],
            Region::Polygon(vec![
                Point::new(1.0, 2.0),
                Point::new(3.0, 4.0),
                Point::new(5.0, 6.0),
                Point::new(7.0, 8.0)
            ])
        );
        let Region::Mask(m) = &r[3] else { panic!() };
        assert_eq!((m.x(), m.y(), m.width(), m.height()), (2, 3, 3, 2));
        assert_eq!(m.data(), &[0, 1, 1, 1, 1, 0]);
        assert_eq!(r[4], Region::Special(0));
        assert_eq!(r[5], Region::Special(2));
        assert_eq!(parse_regions(&write_regions(&r), "t").unwrap(), r);
    }

    #[test]
    fn rejects_bad_lines_with_positions() {
        let e = parse_regions("1,2,3,4\n1,2,x,4\n", "g.txt").unwrap_err();
        assert!(
            matches!(
                e,
                IoError::Parse {
                    line: 2,
                    column: 3,
                    ..
                }
            ),
            "{e}"
        );
        assert!(parse_regions("1,2,3\n", "g").is_err());
        assert!(parse_regions("1\n\n2\n", "g").is_err());
        assert!(parse_regions("m1,1,2,2,5\n", "g").is_err());
        assert!(parse_regions("m1,1,-2,2,0\n", "g").is_err());
        assert!(parse_regions("1.5\n", "g").is_err());
        assert!(parse_regions("1,inf,3,4\n", "g").is_err());
    }

    #[test]
    fn anchor_values_roundtrip() {
        let a = vec![
            Anchor {
                frame: 0,
                direction: Direction::Forward,
            },
            Anchor {
                frame: 50,
                direction: Direction::Forward,
            },
            Anchor {
                frame: 150,
                direction: Direction::Backward,
            },
        ];
        let t = write_anchor_values(&a, 196);
        assert_eq!(parse_anchor_values(&t, "a").unwrap(), a);
    }
}
