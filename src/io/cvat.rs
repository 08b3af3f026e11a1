//! CVAT for video 1.1 XML: import and export of tracks of boxes, polygons and masks.
//!
//! A `<track id label>` holds one shape per frame it was annotated or exported in. Import
//! follows CVAT's semantics:
//!
//! - `outside="1"` hides the object from that frame until its next shape;
//! - a shape with `keyframe="0"` was interpolated by CVAT: its record has
//!   `flags.interpolated = true`; `occluded="1"` sets `flags.occluded`;
//! - frames between two listed shapes (a sparse, hand-written file) are filled as CVAT would
//!   show them: boxes linearly interpolated towards the next shape, polygons and masks
//!   repeated, all marked interpolated; after a track's last shape the object stays until the
//!   end of the task (`<size>`) unless that shape is `outside`;
//! - CVAT frames are 0-based: `record.frame = cvat frame + 1`.
//!
//! Boxes become box records; polygons are rasterised like pycocotools (as CVAT's own COCO
//! export does) and keep the points' extent as their box; `<mask rle left top width height>`
//! holds row-major run lengths inside its box, starting with background (CVAT's encoding),
//! and gets its pixels' tight box. Polygons and masks need `<original_size>`. Polylines,
//! points, ellipses, cuboids and skeletons are reported as unsupported, as are CVAT-for-images
//! files (`<image>` elements). Attributes, `z_order`, `source` and `group_id` are ignored.
//!
//! Export writes one `<track>` per id with a shape in every frame the id is present (a
//! `<mask>` when the record has one, else a `<box>`; `keyframe = !interpolated`), and an
//! `outside="1"` copy of the last shape in the frame after each run of frames when that frame
//! is inside the task, as CVAT does.

use super::coco_video::rle_from_polygon;
use super::{line_col, IoError, Record, RecordFlags, Rle};
use crate::frame::BBox;
use quick_xml::events::Event;
use quick_xml::XmlVersion;
use std::collections::BTreeMap;
use std::fmt::Write as _;

/// Deepest element nesting accepted; CVAT files nest 5 levels, and a bound keeps hostile input
/// from exhausting the stack when the tree is dropped.
const MAX_DEPTH: usize = 64;

/// Largest frame number / task size accepted (see [`super::limits`]): gaps are filled frame
/// by frame, so an absurd frame number must not turn into billions of records.
const MAX_FRAMES: u32 = super::limits::MAX_FRAME;

use super::limits::{id_message, id_ok, MAX_RECORDS, MAX_TOTAL_RUNS};
use super::rle::{bitmap_runs, for_each_run_pixel};

/// Shapes and mask runs a file has expanded to so far.
#[derive(Default)]
struct Budget {
    records: u64,
    runs: u64,
}

/// Task information of a CVAT file.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct CvatMeta {
    /// Task name.
    pub name: String,
    /// Number of frames in the task (`<size>`; 0 when absent).
    pub size: u32,
    /// Frame width (`<original_size><width>`; 0 when absent).
    pub width: u32,
    /// Frame height (0 when absent).
    pub height: u32,
}

/// An imported CVAT file.
#[derive(Debug, Clone, PartialEq)]
pub struct CvatAnnotations {
    /// Task information.
    pub meta: CvatMeta,
    /// Label names: those of `<labels>` in order, then any other label a track uses.
    pub labels: Vec<String>,
    /// All records, sorted by frame then id.
    pub records: Vec<Record>,
}

/// A parsed XML element with the byte offset of its `<`.
#[derive(Debug, Default)]
struct Node {
    name: String,
    attrs: Vec<(String, String)>,
    children: Vec<Node>,
    text: String,
    pos: usize,
}

impl Node {
    fn child(&self, name: &str) -> Option<&Node> {
        self.children.iter().find(|c| c.name == name)
    }

    fn attr(&self, key: &str) -> Option<&str> {
        self.attrs
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_str())
    }
}

struct Ctx<'t> {
    file: &'t str,
    text: &'t str,
}

impl Ctx<'_> {
    fn err(&self, pos: usize, message: impl Into<String>) -> IoError {
        let (line, column) = line_col(self.text, pos);
        IoError::Xml {
            file: self.file.to_string(),
            line,
            column,
            message: message.into(),
        }
    }

    fn req<'n>(&self, n: &'n Node, key: &str) -> Result<&'n str, IoError> {
        n.attr(key)
            .ok_or_else(|| self.err(n.pos, format!("<{}> has no \"{key}\" attribute", n.name)))
    }

    fn num(&self, n: &Node, key: &str) -> Result<f64, IoError> {
        let s = self.req(n, key)?;
        match s.trim().parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            _ => Err(self.err(
                n.pos,
                format!("<{}> attribute {key}={s:?} is not a finite number", n.name),
            )),
        }
    }

    fn uint(&self, n: &Node, key: &str) -> Result<u32, IoError> {
        let s = self.req(n, key)?;
        s.trim().parse::<u32>().map_err(|_| {
            self.err(
                n.pos,
                format!(
                    "<{}> attribute {key}={s:?} is not a non-negative integer",
                    n.name
                ),
            )
        })
    }

    fn flag(&self, n: &Node, key: &str, default: bool) -> Result<bool, IoError> {
        match n.attr(key).map(str::trim) {
            None => Ok(default),
            Some("1") | Some("true") | Some("True") => Ok(true),
            Some("0") | Some("false") | Some("False") => Ok(false),
            Some(s) => Err(self.err(
                n.pos,
                format!("<{}> attribute {key}={s:?} is not 0 or 1", n.name),
            )),
        }
    }

    fn text_uint(&self, n: &Node) -> Result<u32, IoError> {
        n.text.trim().parse::<u32>().map_err(|_| {
            self.err(
                n.pos,
                format!(
                    "<{}> holds {:?}, expected a non-negative integer",
                    n.name, n.text
                ),
            )
        })
    }
}

/// Parses XML text into a tree, turning quick-xml errors and unclosed elements into
/// positioned [`IoError::Xml`]s.
fn parse_tree(ctx: &Ctx) -> Result<Node, IoError> {
    let mut reader = quick_xml::Reader::from_str(ctx.text);
    let mut stack: Vec<Node> = vec![Node::default()];
    let start_of = |end: usize| ctx.text[..end.min(ctx.text.len())].rfind('<').unwrap_or(0);
    loop {
        let ev = reader.read_event().map_err(|e| {
            ctx.err(
                reader.error_position() as usize,
                format!("malformed XML: {e}"),
            )
        })?;
        let end = reader.buffer_position() as usize;
        match ev {
            Event::Start(e) | Event::Empty(e) => {
                let empty = ctx.text.as_bytes().get(end.wrapping_sub(2)) == Some(&b'/');
                let pos = start_of(end);
                let mut node = Node {
                    name: e.name().into_inner().to_string(),
                    pos,
                    ..Node::default()
                };
                for a in e.attributes() {
                    let a = a.map_err(|err| ctx.err(pos, format!("malformed attribute: {err}")))?;
                    let v = a
                        .normalized_value(XmlVersion::Implicit1_0)
                        .map_err(|err| ctx.err(pos, format!("malformed attribute value: {err}")))?;
                    node.attrs
                        .push((a.key.into_inner().to_string(), v.into_owned()));
                }
                if empty {
                    if let Some(parent) = stack.last_mut() {
                        parent.children.push(node);
                    }
                } else {
                    if stack.len() > MAX_DEPTH {
                        return Err(
                            ctx.err(pos, format!("elements nested deeper than {MAX_DEPTH}"))
                        );
                    }
                    stack.push(node);
                }
            }
            Event::End(_) => {
                let node = stack.pop();
                match (node, stack.last_mut()) {
                    (Some(node), Some(parent)) => parent.children.push(node),
                    _ => return Err(ctx.err(start_of(end), "closing tag without an opening one")),
                }
            }
            Event::Text(t) => {
                if let Some(n) = stack.last_mut() {
                    n.text.push_str(&t.xml_content(XmlVersion::Implicit1_0));
                }
            }
            Event::CData(t) => {
                if let Some(n) = stack.last_mut() {
                    n.text.push_str(&t);
                }
            }
            Event::GeneralRef(r) => {
                let ch = r
                    .resolve_char_ref()
                    .map_err(|e| ctx.err(end, format!("bad character reference: {e}")))?;
                let s = match ch {
                    Some(c) => c.to_string(),
                    None => quick_xml::escape::resolve_predefined_entity(&r)
                        .ok_or_else(|| ctx.err(end, format!("unknown entity &{};", &*r)))?
                        .to_string(),
                };
                if let Some(n) = stack.last_mut() {
                    n.text.push_str(&s);
                }
            }
            Event::Eof => break,
            _ => {}
        }
    }
    if stack.len() > 1 {
        let open = stack.last().map_or(0, |n| n.pos);
        let name = stack.last().map_or("", |n| n.name.as_str()).to_string();
        return Err(ctx.err(
            ctx.text.len(),
            format!(
                "document ends inside <{name}> opened at line {}",
                line_col(ctx.text, open).0
            ),
        ));
    }
    let mut doc = stack.pop().unwrap_or_default();
    match doc.children.len() {
        1 => Ok(doc.children.remove(0)),
        0 => Err(ctx.err(0, "no root element")),
        _ => Err(ctx.err(doc.children[1].pos, "more than one root element")),
    }
}

/// A shape as listed in a track.
#[derive(Debug, Clone)]
enum Geometry {
    Box(BBox),
    Polygon(Vec<f64>),
    Mask(Rle),
}

struct Shape {
    frame: u32,
    outside: bool,
    occluded: bool,
    keyframe: bool,
    geometry: Geometry,
}

fn parse_meta(ctx: &Ctx, root: &Node) -> Result<(CvatMeta, Vec<String>), IoError> {
    let mut meta = CvatMeta::default();
    let mut labels = Vec::new();
    let Some(m) = root.child("meta") else {
        return Ok((meta, labels));
    };
    let Some(task) = m.child("task").or_else(|| m.child("job")) else {
        return Ok((meta, labels));
    };
    if let Some(n) = task.child("name") {
        meta.name = n.text.trim().to_string();
    }
    if let Some(n) = task.child("size") {
        meta.size = ctx.text_uint(n)?;
        if meta.size > MAX_FRAMES {
            return Err(ctx.err(
                n.pos,
                format!("task size {} is larger than {MAX_FRAMES}", meta.size),
            ));
        }
    }
    if let Some(o) = task.child("original_size") {
        for (key, slot) in [("width", &mut meta.width), ("height", &mut meta.height)] {
            let n = o
                .child(key)
                .ok_or_else(|| ctx.err(o.pos, format!("<original_size> has no <{key}>")))?;
            *slot = ctx.text_uint(n)?;
        }
        // 64 Mpx at most: masks are decoded to full frames.
        if meta.width > 1 << 16
            || meta.height > 1 << 16
            || meta.width as u64 * meta.height as u64 > 1 << 26
        {
            return Err(ctx.err(
                o.pos,
                "original size is larger than 65536 per side or 64 Mpx",
            ));
        }
    }
    if let Some(ls) = task.child("labels") {
        for l in ls.children.iter().filter(|c| c.name == "label") {
            let n = l
                .child("name")
                .ok_or_else(|| ctx.err(l.pos, "<label> has no <name>"))?;
            labels.push(n.text.trim().to_string());
        }
    }
    Ok((meta, labels))
}

fn parse_shape(ctx: &Ctx, n: &Node, meta: &CvatMeta) -> Result<Shape, IoError> {
    let need_size = || {
        if meta.width == 0 || meta.height == 0 {
            Err(ctx.err(
                n.pos,
                format!(
                    "<{}> needs the frame size (<original_size> in <meta>)",
                    n.name
                ),
            ))
        } else {
            Ok(())
        }
    };
    let geometry = match n.name.as_str() {
        "box" => {
            let (x1, y1) = (ctx.num(n, "xtl")?, ctx.num(n, "ytl")?);
            let (x2, y2) = (ctx.num(n, "xbr")?, ctx.num(n, "ybr")?);
            if x2 < x1 || y2 < y1 {
                return Err(ctx.err(n.pos, "box has xbr < xtl or ybr < ytl"));
            }
            Geometry::Box(BBox::new(x1, y1, x2 - x1, y2 - y1))
        }
        "polygon" => {
            need_size()?;
            let pts = ctx.req(n, "points")?;
            let mut xy = Vec::new();
            for p in pts.split(';').map(str::trim).filter(|p| !p.is_empty()) {
                let mut it = p.split(',');
                let (Some(x), Some(y), None) = (it.next(), it.next(), it.next()) else {
                    return Err(ctx.err(n.pos, format!("polygon point {p:?} is not \"x,y\"")));
                };
                for v in [x, y] {
                    match v.trim().parse::<f64>() {
                        Ok(f) if f.is_finite() => xy.push(f),
                        _ => {
                            return Err(
                                ctx.err(n.pos, format!("polygon coordinate {v:?} is not a number"))
                            )
                        }
                    }
                }
            }
            if xy.len() < 6 {
                return Err(ctx.err(n.pos, "polygon has fewer than 3 points"));
            }
            Geometry::Polygon(xy)
        }
        "mask" => {
            need_size()?;
            let (left, top) = (ctx.uint(n, "left")?, ctx.uint(n, "top")?);
            let (w, h) = (ctx.uint(n, "width")?, ctx.uint(n, "height")?);
            if left as u64 + w as u64 > meta.width as u64
                || top as u64 + h as u64 > meta.height as u64
            {
                return Err(ctx.err(
                    n.pos,
                    format!(
                        "mask box {w}x{h} at ({left}, {top}) leaves the {}x{} frame",
                        meta.width, meta.height
                    ),
                ));
            }
            let rle = ctx.req(n, "rle")?;
            let mut runs = Vec::new();
            for v in rle.split(',').map(str::trim).filter(|v| !v.is_empty()) {
                runs.push(v.parse::<u64>().map_err(|_| {
                    ctx.err(
                        n.pos,
                        format!("mask rle value {v:?} is not a non-negative integer"),
                    )
                })?);
            }
            // Checked: run lengths near 2⁶⁴ must not wrap around to the box's area.
            let total = runs.iter().try_fold(0u64, |a, &r| a.checked_add(r));
            if total != Some(w as u64 * h as u64) {
                return Err(ctx.err(
                    n.pos,
                    format!(
                        "mask rle covers {} pixels but its box is {w}x{h}",
                        total.map_or("more than 2^64".to_string(), |t| t.to_string())
                    ),
                ));
            }
            let mut full = vec![0u8; meta.width as usize * meta.height as usize];
            for_each_run_pixel(&runs, w as u64, |y, x| {
                full[(top as usize + y as usize) * meta.width as usize
                    + left as usize
                    + x as usize] = 1;
            });
            let rle = Rle::encode(meta.width, meta.height, &full)
                .map_err(|e| ctx.err(n.pos, e.to_string()))?;
            Geometry::Mask(rle)
        }
        "polyline" | "points" | "ellipse" | "cuboid" | "skeleton" => {
            return Err(ctx.err(n.pos, format!("<{}> shapes are not supported", n.name)));
        }
        other => return Err(ctx.err(n.pos, format!("unknown shape <{other}> in a track"))),
    };
    let frame = ctx.uint(n, "frame")?;
    if frame >= MAX_FRAMES {
        return Err(ctx.err(n.pos, format!("frame {frame} is larger than {MAX_FRAMES}")));
    }
    Ok(Shape {
        frame,
        outside: ctx.flag(n, "outside", false)?,
        occluded: ctx.flag(n, "occluded", false)?,
        keyframe: ctx.flag(n, "keyframe", true)?,
        geometry,
    })
}

fn record_of(
    ctx: &Ctx,
    pos: usize,
    frame: u32,
    id: i64,
    class: i32,
    g: &Geometry,
    meta: &CvatMeta,
) -> Result<Record, IoError> {
    let (bbox, mask) = match g {
        Geometry::Box(b) => (*b, None),
        Geometry::Polygon(xy) => {
            let rle = rle_from_polygon(xy, meta.height, meta.width)
                .map_err(|e| ctx.err(pos, format!("bad polygon: {e}")))?;
            let xs = xy.iter().step_by(2);
            let ys = xy.iter().skip(1).step_by(2);
            let (x0, x1) = xs.fold((f64::MAX, f64::MIN), |(a, b), &v| (a.min(v), b.max(v)));
            let (y0, y1) = ys.fold((f64::MAX, f64::MIN), |(a, b), &v| (a.min(v), b.max(v)));
            (BBox::from_xyxy(x0, y0, x1, y1), Some(rle))
        }
        Geometry::Mask(rle) => (rle.bbox(), Some(rle.clone())),
    };
    Ok(Record {
        frame: frame + 1,
        id,
        bbox,
        score: 1.0,
        class,
        visibility: -1.0,
        mask,
        flags: RecordFlags::default(),
    })
}

/// Parses a CVAT for video 1.1 XML file. `file` names it in errors.
///
/// With `labels` (class → name), a track's class is the class of its label name (an unknown
/// name is an error); without, it is the label's index in [`CvatAnnotations::labels`].
pub fn parse_cvat(
    text: &str,
    file: &str,
    labels: Option<&BTreeMap<i32, String>>,
) -> Result<CvatAnnotations, IoError> {
    let ctx = Ctx { file, text };
    let root = parse_tree(&ctx)?;
    if root.name != "annotations" {
        return Err(ctx.err(
            root.pos,
            format!("root element is <{}>, expected <annotations>", root.name),
        ));
    }
    if let Some(v) = root.child("version") {
        if !v.text.trim().starts_with("1.") {
            return Err(ctx.err(
                v.pos,
                format!("unsupported CVAT XML version {:?}", v.text.trim()),
            ));
        }
    }
    let (meta, mut names) = parse_meta(&ctx, &root)?;
    let mut records = Vec::new();
    let mut budget = Budget::default();
    let mut ids = std::collections::BTreeSet::new();
    for node in &root.children {
        match node.name.as_str() {
            "track" => {}
            "image" => {
                return Err(ctx.err(
                    node.pos,
                    "CVAT for images files are not supported; export \"CVAT for video 1.1\"",
                ));
            }
            _ => continue,
        }
        let id: i64 = {
            let s = ctx.req(node, "id")?;
            s.trim()
                .parse()
                .map_err(|_| ctx.err(node.pos, format!("track id {s:?} is not an integer")))?
        };
        if !id_ok(id) {
            return Err(ctx.err(node.pos, id_message(&id.to_string())));
        }
        if !ids.insert(id) {
            return Err(ctx.err(node.pos, format!("duplicate track id {id}")));
        }
        let label = ctx.req(node, "label")?;
        let class = match labels {
            Some(map) => {
                *map.iter()
                    .find(|(_, n)| n.as_str() == label)
                    .ok_or_else(|| {
                        ctx.err(node.pos, format!("label {label:?} is not in the label map"))
                    })?
                    .0
            }
            None => match names.iter().position(|n| n == label) {
                Some(i) => i as i32,
                None => {
                    names.push(label.to_string());
                    names.len() as i32 - 1
                }
            },
        };
        let mut shapes: Vec<(usize, Shape)> = Vec::new();
        for s in &node.children {
            if s.name == "attribute" {
                continue;
            }
            shapes.push((s.pos, parse_shape(&ctx, s, &meta)?));
        }
        shapes.sort_by_key(|(_, s)| s.frame);
        for w in shapes.windows(2) {
            if w[0].1.frame == w[1].1.frame {
                return Err(ctx.err(
                    w[1].0,
                    format!("track {id} has two shapes in frame {}", w[1].1.frame),
                ));
            }
        }
        for (i, (pos, s)) in shapes.iter().enumerate() {
            if meta.size > 0 && s.frame >= meta.size {
                return Err(ctx.err(
                    *pos,
                    format!(
                        "frame {} is outside the task's {} frames",
                        s.frame, meta.size
                    ),
                ));
            }
            if s.outside {
                continue;
            }
            let mut r = record_of(&ctx, *pos, s.frame, id, class, &s.geometry, &meta)?;
            r.flags = RecordFlags {
                interpolated: !s.keyframe,
                occluded: s.occluded,
            };
            records.push(r);
            // Frames up to the next shape (or the end of the task) that the file leaves out.
            let next = shapes.get(i + 1).map(|(_, n)| n);
            let stop = next.map_or(meta.size.max(s.frame + 1), |n| n.frame);
            // A few bytes of keyframes may span a million frames: bound what they expand to.
            let span = (stop - s.frame) as u64;
            let runs = match &s.geometry {
                Geometry::Mask(r) => r.counts.len() as u64,
                Geometry::Polygon(xy) => 2 * meta.width.max(1) as u64 + xy.len() as u64,
                Geometry::Box(_) => 0,
            };
            budget.records += span;
            budget.runs += span * runs;
            if budget.records > MAX_RECORDS || budget.runs > MAX_TOTAL_RUNS {
                return Err(ctx.err(
                    *pos,
                    format!(
                        "the file expands to more than {MAX_RECORDS} shapes or {MAX_TOTAL_RUNS} \
                         mask runs (keyframes far apart?); split the task"
                    ),
                ));
            }
            // A held polygon or mask is rasterised once, not once per frame it is held for.
            let mut held: Option<Record> = None;
            for f in s.frame + 1..stop {
                let mut r = match (&s.geometry, next.map(|n| &n.geometry)) {
                    (Geometry::Box(a), Some(Geometry::Box(b))) => {
                        let t = (f - s.frame) as f64 / (stop - s.frame) as f64;
                        let g = Geometry::Box(BBox::new(
                            a.x + (b.x - a.x) * t,
                            a.y + (b.y - a.y) * t,
                            a.w + (b.w - a.w) * t,
                            a.h + (b.h - a.h) * t,
                        ));
                        record_of(&ctx, *pos, f, id, class, &g, &meta)?
                    }
                    (g, _) => {
                        let mut r = match &held {
                            Some(r) => r.clone(),
                            None => {
                                let r = record_of(&ctx, *pos, f, id, class, g, &meta)?;
                                held = Some(r.clone());
                                r
                            }
                        };
                        r.frame = f + 1;
                        r
                    }
                };
                r.flags = RecordFlags {
                    interpolated: true,
                    occluded: s.occluded,
                };
                records.push(r);
            }
        }
    }
    records.sort_by_key(|r| (r.frame, r.id));
    Ok(CvatAnnotations {
        meta,
        labels: names,
        records,
    })
}

fn esc(s: &str) -> std::borrow::Cow<'_, str> {
    quick_xml::escape::escape(s)
}

/// Writes one shape element (without a trailing newline).
fn write_shape(out: &mut String, r: &Record, cvat_frame: u32, outside: bool, keyframe: bool) {
    let common = format!(
        "frame=\"{cvat_frame}\" outside=\"{}\" occluded=\"{}\" keyframe=\"{}\"",
        outside as u8, r.flags.occluded as u8, keyframe as u8
    );
    match r.mask.as_ref().map(Rle::to_mask) {
        Some(m) if !m.is_empty() => {
            // CVAT's encoding: row-major runs inside the mask's box, background first.
            let rle: Vec<String> = bitmap_runs(m.data()).iter().map(u64::to_string).collect();
            let _ = write!(
                out,
                "    <mask {common} rle=\"{}\" left=\"{}\" top=\"{}\" width=\"{}\" height=\"{}\" z_order=\"0\"></mask>",
                rle.join(", "),
                m.x(),
                m.y(),
                m.width(),
                m.height()
            );
        }
        _ => {
            let b = &r.bbox;
            let _ = write!(
                out,
                "    <box {common} xtl=\"{}\" ytl=\"{}\" xbr=\"{}\" ybr=\"{}\" z_order=\"0\"></box>",
                b.x,
                b.y,
                b.x2(),
                b.y2()
            );
        }
    }
}

/// Writes records as CVAT for video 1.1 XML. `labels` maps classes to label names (every
/// record's class must be in it); `meta.size` bounds the frames (records must be in
/// `1..=size`) and `meta.width/height` are written as `<original_size>`. A record whose mask
/// is empty is written as its box.
pub fn write_cvat(
    records: &[Record],
    meta: &CvatMeta,
    labels: &BTreeMap<i32, String>,
) -> Result<String, IoError> {
    let invalid = |message: String| IoError::Invalid {
        file: "<cvat output>".to_string(),
        line: 0,
        message,
    };
    let mut tracks: BTreeMap<i64, Vec<&Record>> = BTreeMap::new();
    for r in records {
        if r.frame < 1 || r.frame > meta.size {
            return Err(invalid(format!(
                "record of id {} is in frame {} outside the task's frames 1..={}",
                r.id, r.frame, meta.size
            )));
        }
        tracks.entry(r.id).or_default().push(r);
    }
    let mut out = String::new();
    out.push_str("<?xml version=\"1.0\" encoding=\"utf-8\"?>\n<annotations>\n  <version>1.1</version>\n  <meta>\n    <task>\n");
    let _ = writeln!(out, "      <name>{}</name>", esc(&meta.name));
    let _ = writeln!(out, "      <size>{}</size>", meta.size);
    out.push_str("      <mode>interpolation</mode>\n      <overlap>0</overlap>\n");
    let _ = writeln!(
        out,
        "      <start_frame>0</start_frame>\n      <stop_frame>{}</stop_frame>",
        meta.size.saturating_sub(1)
    );
    out.push_str("      <labels>\n");
    for name in labels.values() {
        let _ = writeln!(out, "        <label>\n          <name>{}</name>\n          <attributes>\n          </attributes>\n        </label>", esc(name));
    }
    out.push_str("      </labels>\n");
    let _ = writeln!(
        out,
        "      <original_size>\n        <width>{}</width>\n        <height>{}</height>\n      </original_size>",
        meta.width, meta.height
    );
    out.push_str("    </task>\n  </meta>\n");
    for (id, mut rs) in tracks {
        rs.sort_by_key(|r| r.frame);
        if let Some(w) = rs.windows(2).find(|w| w[0].frame == w[1].frame) {
            return Err(invalid(format!(
                "id {id} appears twice in frame {}",
                w[0].frame
            )));
        }
        let class = rs[0].class;
        if let Some(r) = rs.iter().find(|r| r.class != class) {
            return Err(invalid(format!(
                "id {id} has classes {class} and {}; a CVAT track has one label",
                r.class
            )));
        }
        let label = labels
            .get(&class)
            .ok_or_else(|| invalid(format!("class {class} of id {id} has no label name")))?;
        let _ = writeln!(
            out,
            "  <track id=\"{id}\" label=\"{}\" source=\"manual\">",
            esc(label)
        );
        for (i, r) in rs.iter().enumerate() {
            write_shape(&mut out, r, r.frame - 1, false, !r.flags.interpolated);
            out.push('\n');
            let next_present = rs.get(i + 1).is_some_and(|n| n.frame == r.frame + 1);
            if !next_present && r.frame < meta.size {
                // The object leaves after this run: CVAT marks the next frame outside.
                write_shape(&mut out, r, r.frame, true, true);
                out.push('\n');
            }
        }
        out.push_str("  </track>\n");
    }
    out.push_str("</annotations>\n");
    Ok(out)
}
