//! `shapetrack bench`: frames per second of the online tracker, and where the time goes, on
//! synthetic scenes by resolution, number of shapes and mode (boxes without frames, or masks
//! with frames and the mask preset), single-threaded.
//!
//! Each scene is rendered first (not timed); then the tracker runs over its frames with a
//! clock ([`Tracker::with_clock`]), which splits the time into the phases of
//! [`shapetrack::track::PhaseTimes`]. `fps` counts the tracker only: no rendering, no
//! detection, no file input/output.
//!
//! After the rows, per resolution and mode, how the time grew from the fewest shapes to the
//! most (a fixed frame: more shapes is also a denser crowd), and, for rows with as many shapes
//! per pixel (`--resolutions 640x480,2024x1518 --shapes 20,200`), how it grew at constant
//! density.

use serde::Serialize;
use shapetrack::synth::{Scene, SynthConfig, SynthFrame};
use shapetrack::track::offline::{OfflineConfig, OfflineTracker, RleHistory};
use shapetrack::track::{Config, PhaseTimes, Tracker};
use std::path::PathBuf;
use std::time::Instant;

/// Tracking modes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Mode {
    /// Box detections, no frames, default config (MOTChallenge det.txt style).
    Box,
    /// Mask detections with their frames, mask preset (appearance where needed).
    Mask,
}

/// Arguments of `shapetrack bench`.
#[derive(clap::Args)]
pub struct Args {
    /// Frame sizes, `WxH`, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "640x480,1280x720")]
    resolutions: Vec<String>,
    /// Numbers of shapes alive at once, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "5,10,20,50")]
    shapes: Vec<u32>,
    /// Modes, comma-separated.
    #[arg(long, value_enum, value_delimiter = ',', default_value = "box,mask")]
    modes: Vec<Mode>,
    /// Frames per scene.
    #[arg(long, default_value_t = 100)]
    frames: u32,
    /// Scene seed.
    #[arg(long, default_value_t = 7)]
    seed: u64,
    /// Also write the rows as JSON to this file.
    #[arg(long)]
    json: Option<PathBuf>,
    /// Also compare the browser build with native on these app scenes (`demo`, `default`,
    /// `occlusion`), masks with frames: the same scene tracked natively here and in wasm under
    /// Node (`scripts/bench-wasm.mjs --paired`, needs `node` and the built `www/pkg`), one
    /// pass each in turn, and the median ratio of their times per frame.
    #[arg(long, value_delimiter = ',')]
    wasm: Vec<WasmScene>,
}

/// The synthetic scenes the app (and the wasm `SynthScene`) offers.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum WasmScene {
    /// 1280×720, 600 frames (the app's demo).
    Demo,
    /// 640×480, 300 frames.
    Default,
    /// 640×480, 300 frames, objects passing behind occluders.
    Occlusion,
}

impl WasmScene {
    fn name(self) -> &'static str {
        match self {
            WasmScene::Demo => "demo",
            WasmScene::Default => "default",
            WasmScene::Occlusion => "occlusion",
        }
    }

    /// The scene's settings: the same constructors the wasm `SynthScene` uses.
    fn config(self) -> SynthConfig {
        match self {
            WasmScene::Demo => SynthConfig::demo(),
            WasmScene::Default => SynthConfig::default(),
            WasmScene::Occlusion => SynthConfig::occlusion_scene(0),
        }
    }
}

/// One measured configuration. Times are milliseconds per frame.
#[derive(Debug, Serialize)]
struct Row {
    width: u32,
    height: u32,
    shapes: u32,
    mode: Mode,
    frames: u64,
    detections_per_frame: f64,
    fps: f64,
    ms_per_frame: f64,
    features_ms: f64,
    regions_ms: f64,
    costs_ms: f64,
    assignment_ms: f64,
    update_ms: f64,
}

fn parse_resolution(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s
        .trim()
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("resolution {s:?}: expected WxH, e.g. 640x480"))?;
    let p = |v: &str| {
        v.trim()
            .parse::<u32>()
            .ok()
            .filter(|&n| n > 0)
            .ok_or_else(|| format!("resolution {s:?}: {v:?} is not a positive integer"))
    };
    Ok((p(w)?, p(h)?))
}

fn measure(frames: &[SynthFrame], mode: Mode) -> Result<PhaseTimes, Box<dyn std::error::Error>> {
    let config = match mode {
        Mode::Box => Config::default(),
        Mode::Mask => Config::masks(),
    };
    let start = Instant::now();
    let mut tracker = Tracker::new(config)?.with_clock(move || start.elapsed().as_secs_f64());
    for f in frames {
        match mode {
            Mode::Box => tracker.update(None, &f.box_detections)?,
            Mode::Mask => tracker.update(Some(&f.frame()?), &f.detections)?,
        };
    }
    Ok(tracker.phase_times())
}

/// Runs the subcommand.
pub fn run(args: Args) -> crate::CliResult {
    if args.frames == 0 {
        return Err("--frames must be at least 1".into());
    }
    let resolutions = args
        .resolutions
        .iter()
        .map(|r| parse_resolution(r))
        .collect::<Result<Vec<_>, _>>()?;
    let mut rows = Vec::new();
    println!(
        "{:>9} {:>6} {:>4} {:>7} {:>8} {:>9} | {:>8} {:>7} {:>7} {:>7} {:>7}  (ms/frame)",
        "size",
        "shapes",
        "mode",
        "dets/f",
        "fps",
        "ms/frame",
        "features",
        "regions",
        "costs",
        "assign",
        "update"
    );
    for &(width, height) in &resolutions {
        for &shapes in &args.shapes {
            let cfg = SynthConfig {
                seed: args.seed,
                frames: args.frames,
                shapes,
                width,
                height,
                ..SynthConfig::default()
            };
            let frames: Vec<SynthFrame> = Scene::new(cfg)?.collect();
            let dets = frames.iter().map(|f| f.detections.len()).sum::<usize>() as f64
                / frames.len().max(1) as f64;
            for &mode in &args.modes {
                let t = measure(&frames, mode)?;
                let n = t.frames.max(1) as f64;
                let ms = |s: f64| 1e3 * s / n;
                let total = t.total();
                let row = Row {
                    width,
                    height,
                    shapes,
                    mode,
                    frames: t.frames,
                    detections_per_frame: dets,
                    fps: if total > 0.0 {
                        n / total
                    } else {
                        f64::INFINITY
                    },
                    ms_per_frame: ms(total),
                    features_ms: ms(t.features),
                    regions_ms: ms(t.regions),
                    costs_ms: ms(t.costs),
                    assignment_ms: ms(t.assignment),
                    update_ms: ms(t.update),
                };
                println!(
                    "{:>9} {:>6} {:>4} {:>7.1} {:>8.0} {:>9.3} | {:>8.3} {:>7.3} {:>7.3} {:>7.3} {:>7.3}",
                    format!("{width}x{height}"),
                    shapes,
                    match mode {
                        Mode::Box => "box",
                        Mode::Mask => "mask",
                    },
                    row.detections_per_frame,
                    row.fps,
                    row.ms_per_frame,
                    row.features_ms,
                    row.regions_ms,
                    row.costs_ms,
                    row.assignment_ms,
                    row.update_ms
                );
                rows.push(row);
            }
        }
    }
    for line in scaling(&rows) {
        println!("{line}");
    }
    for &scene in &args.wasm {
        println!("{}", wasm_vs_native(scene)?);
    }
    if let Some(path) = &args.json {
        let text = serde_json::to_string_pretty(&rows)?;
        shapetrack::io::write_text(path, &text)?;
    }
    Ok(())
}

/// The milliseconds per frame of what the browser bindings' `Tracker.update` runs in Rust
/// (`wasm::Tracker` with `{ preset: 'masks' }` and no offline options): the online tracker
/// inside an [`OfflineTracker`] keeping the shapes with RLE masks, appearance snapshots off.
/// Only the shapes' conversion to JS objects is left to the wasm side.
fn binding_path_ms(frames: &[SynthFrame]) -> Result<f64, Box<dyn std::error::Error>> {
    let cfg = Config::masks();
    let mut offline = OfflineConfig {
        online: cfg.clone(),
        ..OfflineConfig::default()
    };
    offline.appearance.enabled = false;
    let mut tracker: OfflineTracker<RleHistory> =
        OfflineTracker::with_history(Tracker::new(cfg)?, offline, 1.0)?;
    let mut total = 0.0;
    for f in frames {
        let frame = f.frame()?;
        let start = Instant::now();
        tracker.push_frame(Some(&frame), &f.detections)?;
        total += start.elapsed().as_secs_f64();
    }
    Ok(1e3 * total / frames.len().max(1) as f64)
}

/// The wasm side of `--wasm`: `scripts/bench-wasm.mjs --paired` under Node, which warms V8
/// up and then runs one pass over the scene per line it reads.
struct WasmSide {
    child: std::process::Child,
    stdin: std::process::ChildStdin,
    lines: std::io::Lines<std::io::BufReader<std::process::ChildStdout>>,
    /// Its ready line (the first pass' time, while V8 compiles).
    ready: serde_json::Value,
}

impl WasmSide {
    fn start(scene: WasmScene) -> Result<Self, Box<dyn std::error::Error>> {
        use std::io::BufRead;
        use std::process::{Command, Stdio};
        let script =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scripts/bench-wasm.mjs");
        let mut child = Command::new("node")
            .arg(&script)
            .args(["--scene", scene.name(), "--paired"])
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .spawn()
            .map_err(|e| format!("--wasm runs `node {}`: {e}", script.display()))?;
        let (Some(stdin), Some(stdout)) = (child.stdin.take(), child.stdout.take()) else {
            return Err("node's stdin or stdout is not piped".into());
        };
        let mut side = WasmSide {
            child,
            stdin,
            lines: std::io::BufReader::new(stdout).lines(),
            ready: serde_json::Value::Null,
        };
        side.ready = side
            .read()
            .map_err(|e| format!("{e} (build the wasm first: node scripts/build-wasm.mjs)"))?;
        Ok(side)
    }

    fn read(&mut self) -> Result<serde_json::Value, Box<dyn std::error::Error>> {
        let line = self
            .lines
            .next()
            .ok_or("bench-wasm.mjs ended early (its error is above)")??;
        Ok(serde_json::from_str(&line)?)
    }

    /// One pass: milliseconds per frame and the JSON line (its phases).
    fn pass(&mut self) -> Result<(f64, serde_json::Value), Box<dyn std::error::Error>> {
        use std::io::Write;
        writeln!(self.stdin, "pass")?;
        self.stdin.flush()?;
        let v = self.read()?;
        let ms = v["ms_per_frame"]
            .as_f64()
            .ok_or("bench-wasm.mjs printed no ms_per_frame")?;
        Ok((ms, v))
    }
}

impl Drop for WasmSide {
    fn drop(&mut self) {
        // Closing stdin ends the script; a script stuck elsewhere is killed.
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// The median of `v`, which it leaves sorted (the caller then reads the extremes); NaN when
/// empty.
fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    match v.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => v[n / 2],
        n => 0.5 * (v[n / 2 - 1] + v[n / 2]),
    }
}

/// Tracks an app scene natively (mask mode) along the path the browser bindings take and in
/// wasm under Node, one pass each in turn, and says how the two compare (issue 10's target:
/// wasm at most 1.4× native). Passes come in pairs, which side goes first alternating, for at
/// least `MIN_PAIRS` pairs and `MIN_SECONDS` of tracking per side: on a shared machine the
/// two sides of a pair meet the same busy or quiet spell, where separate runs of each side
/// gave one session ×1.13 to ×1.83 on the demo scene. The figure is the median of the pairs'
/// ratios; the ratio of each side's fastest pass is printed beside it. The tracker's own
/// phases are printed too (natively from a separate clocked pass).
fn wasm_vs_native(scene: WasmScene) -> Result<String, Box<dyn std::error::Error>> {
    const MIN_PAIRS: usize = 9;
    const MIN_SECONDS: f64 = 4.0;
    const MAX_PAIRS: usize = 60;
    let frames: Vec<SynthFrame> = Scene::new(scene.config())?.collect();
    let t = measure(&frames, Mode::Mask)?;
    let core = 1e3 * t.total() / t.frames.max(1) as f64;
    let mut wasm_side = WasmSide::start(scene)?;
    // The native side's warm-up (the allocator and caches; V8's is done in the script).
    binding_path_ms(&frames)?;
    let seconds = |ms: f64| ms * frames.len() as f64 / 1e3;
    let (mut natives, mut wasms, mut ratios) = (Vec::new(), Vec::new(), Vec::new());
    let mut fastest: Option<(f64, serde_json::Value)> = None;
    let mut spent = 0.0f64;
    while ratios.len() < MAX_PAIRS && (ratios.len() < MIN_PAIRS || spent < MIN_SECONDS) {
        let native_first = ratios.len() % 2 == 0;
        let mut n = f64::NAN;
        if native_first {
            n = binding_path_ms(&frames)?;
        }
        let (w, v) = wasm_side.pass()?;
        if !native_first {
            n = binding_path_ms(&frames)?;
        }
        spent += seconds(n.min(w));
        natives.push(n);
        wasms.push(w);
        ratios.push(w / n.max(1e-9));
        if fastest.as_ref().is_none_or(|(b, _)| w < *b) {
            fastest = Some((w, v));
        }
    }
    let pairs = ratios.len();
    let ratio = median(&mut ratios);
    let native = natives.iter().copied().fold(f64::INFINITY, f64::min);
    let (wasm, v) = fastest.ok_or("no wasm pass ran")?;
    let (native_median, wasm_median) = (median(&mut natives), median(&mut wasms));
    let spread = format!(
        "pairs' ratios ×{:.2} to ×{:.2}",
        ratios.first().copied().unwrap_or(f64::NAN),
        ratios.last().copied().unwrap_or(f64::NAN)
    );
    let first = wasm_side.ready["first_pass_ms_per_frame"]
        .as_f64()
        .map_or(String::new(), |f| {
            format!(
                "; wasm's first pass, while V8 compiles: {f:.2} ms/frame, ×{:.2}",
                f / native_median.max(1e-9)
            )
        });
    // Phase by phase (ms/frame, native → wasm's fastest pass): where wasm's extra time goes,
    // and how much of it is outside the tracker (the crossing into wasm and the shapes back
    // to JS).
    let n = t.frames.max(1) as f64;
    let native_phases =
        [t.features, t.regions, t.costs, t.assignment, t.update].map(|s| 1e3 * s / n);
    let names = ["features", "regions", "costs", "assignment", "update"];
    let mut phases = Vec::new();
    let mut wasm_core = 0.0;
    for (name, nat) in names.iter().zip(native_phases) {
        if let Some(w) = v["phases"][name].as_f64() {
            wasm_core += w;
            phases.push(format!("{name} {nat:.3} → {w:.3}"));
        }
    }
    let phases = if phases.is_empty() {
        String::new()
    } else {
        format!(
            "\n  phases ms/frame native → wasm: {}; outside the tracker: native {:.3}, wasm {:.3}",
            phases.join(", "),
            native - core,
            wasm - wasm_core
        )
    };
    Ok(format!(
        "wasm vs native, scene {} ({}x{}, {} frames, masks), {pairs} pairs of passes in turn: ×{ratio:.2} (median of the pairs; {spread}); median pass native {native_median:.2} ms/frame (the bindings' path; the tracker's phases alone {core:.2}), wasm (Node) {wasm_median:.2}; fastest pass native {native:.2}, wasm {wasm:.2} (×{:.2}){first}{phases}",
        scene.name(),
        frames.first().map_or(0, |f| f.width),
        frames.first().map_or(0, |f| f.height),
        frames.len(),
        wasm / native.max(1e-9),
    ))
}

/// Per resolution and mode, how the time per frame grows from the fewest shapes measured to
/// the most, against how the shapes grew (linear work would grow alike): issue 10's target is
/// 200 shapes at most 12× the 20-shape time. Ratios within one run, so a busy machine slows
/// both ends alike. Then, where rows hold as many shapes per pixel, the growth at constant
/// density ([`density_scaling`]).
fn scaling(rows: &[Row]) -> Vec<String> {
    let mut out = Vec::new();
    let mut keys: Vec<(u32, u32, Mode)> = Vec::new();
    for r in rows {
        if !keys.contains(&(r.width, r.height, r.mode)) {
            keys.push((r.width, r.height, r.mode));
        }
    }
    for (w, h, mode) in keys {
        let group: Vec<&Row> = rows
            .iter()
            .filter(|r| (r.width, r.height, r.mode) == (w, h, mode))
            .collect();
        let (Some(lo), Some(hi)) = (
            group.iter().min_by_key(|r| r.shapes),
            group.iter().max_by_key(|r| r.shapes),
        ) else {
            continue;
        };
        if hi.shapes <= lo.shapes || lo.ms_per_frame <= 0.0 {
            continue;
        }
        out.push(format!(
            "scaling {w}x{h} {}: {} vs {} shapes (×{:.1}): time ×{:.1}",
            match mode {
                Mode::Box => "box",
                Mode::Mask => "mask",
            },
            hi.shapes,
            lo.shapes,
            hi.shapes as f64 / lo.shapes as f64,
            hi.ms_per_frame / lo.ms_per_frame
        ));
    }
    out.extend(density_scaling(rows));
    out
}

/// Shapes per pixel of two frame sizes count as equal within this relative difference
/// (2024×1518 holds 10.0014 times the pixels of 640×480).
const SAME_DENSITY: f64 = 0.02;

/// Per mode, how the time per frame grows between two rows with as many shapes per pixel
/// (more shapes on a proportionally larger frame): the growth that comes from the number of
/// shapes alone. At a fixed frame size, ten times the shapes is also ten times the crowding:
/// each shape meets ten times the neighbours, and the pairs geometry cannot decide (where
/// appearance is compared) grow with them. This line separates the two.
fn density_scaling(rows: &[Row]) -> Vec<String> {
    let area = |r: &Row| f64::from(r.width) * f64::from(r.height);
    let mut out = Vec::new();
    for lo in rows {
        for hi in rows {
            if hi.mode != lo.mode || hi.shapes <= lo.shapes || lo.ms_per_frame <= 0.0 {
                continue;
            }
            let (shapes, pixels) = (
                f64::from(hi.shapes) / f64::from(lo.shapes),
                area(hi) / area(lo),
            );
            if (pixels / shapes - 1.0).abs() > SAME_DENSITY {
                continue;
            }
            out.push(format!(
                "scaling {} at constant density: {} shapes at {}x{} vs {} at {}x{} (×{:.1}): time ×{:.1}",
                match lo.mode {
                    Mode::Box => "box",
                    Mode::Mask => "mask",
                },
                hi.shapes,
                hi.width,
                hi.height,
                lo.shapes,
                lo.width,
                lo.height,
                shapes,
                hi.ms_per_frame / lo.ms_per_frame
            ));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn resolutions_parse() {
        assert_eq!(parse_resolution("640x480"), Ok((640, 480)));
        assert_eq!(parse_resolution(" 1280X720 "), Ok((1280, 720)));
        assert!(parse_resolution("640").is_err());
        assert!(parse_resolution("0x10").is_err());
        assert!(parse_resolution("ax10").is_err());
    }

    fn row(shapes: u32, mode: Mode, ms: f64) -> Row {
        Row {
            width: 640,
            height: 480,
            shapes,
            mode,
            frames: 10,
            detections_per_frame: shapes as f64,
            fps: 1e3 / ms,
            ms_per_frame: ms,
            features_ms: 0.0,
            regions_ms: 0.0,
            costs_ms: 0.0,
            assignment_ms: 0.0,
            update_ms: 0.0,
        }
    }

    #[test]
    fn median_of_odd_and_even_counts() {
        assert_eq!(median(&mut [3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&mut [4.0, 1.0, 3.0, 2.0]), 2.5);
        assert!(median(&mut []).is_nan());
        // Sorted in place: the caller reads the smallest and largest after it.
        let mut v = [0.9, 1.8, 1.2];
        median(&mut v);
        assert_eq!(v, [0.9, 1.2, 1.8]);
    }

    #[test]
    fn scaling_compares_the_fewest_and_most_shapes_per_mode() {
        let rows = [
            row(20, Mode::Box, 1.0),
            row(20, Mode::Mask, 5.0),
            row(50, Mode::Box, 2.0),
            row(50, Mode::Mask, 30.0),
            row(200, Mode::Box, 9.0),
            row(200, Mode::Mask, 400.0),
        ];
        // Rows come per shape count, modes interleaved: one line per (resolution, mode).
        let lines = scaling(&rows);
        assert_eq!(
            lines,
            [
                "scaling 640x480 box: 200 vs 20 shapes (×10.0): time ×9.0",
                "scaling 640x480 mask: 200 vs 20 shapes (×10.0): time ×80.0"
            ]
        );
        assert!(scaling(&rows[..2]).is_empty());
    }

    #[test]
    fn density_scaling_pairs_rows_with_as_many_shapes_per_pixel() {
        let at = |w: u32, h: u32, shapes: u32, mode: Mode, ms: f64| Row {
            width: w,
            height: h,
            ..row(shapes, mode, ms)
        };
        let rows = [
            at(640, 480, 20, Mode::Mask, 0.5),
            at(640, 480, 200, Mode::Mask, 9.0),
            at(2024, 1518, 20, Mode::Mask, 0.4),
            at(2024, 1518, 200, Mode::Mask, 5.5),
            at(2024, 1518, 200, Mode::Box, 1.0),
            at(1280, 960, 80, Mode::Mask, 2.1),
        ];
        // 200 at 2024×1518 and 80 at 1280×960 hold 20 at 640×480's density (and so each
        // other's); the box row has no partner of its mode, and the other pairs are 10× or
        // 0.1× as crowded.
        assert_eq!(
            density_scaling(&rows),
            [
                "scaling mask at constant density: 200 shapes at 2024x1518 vs 20 at 640x480 (×10.0): time ×11.0",
                "scaling mask at constant density: 80 shapes at 1280x960 vs 20 at 640x480 (×4.0): time ×4.2",
                "scaling mask at constant density: 200 shapes at 2024x1518 vs 80 at 1280x960 (×2.5): time ×2.6"
            ]
        );
        // The per-resolution lines (two of the four sizes and modes have two rows) come
        // first, then these.
        let lines = scaling(&rows);
        assert_eq!(lines.len(), 5);
        assert!(lines[1].starts_with("scaling 2024x1518 mask: 200 vs 20"));
        assert!(lines[2].contains("constant density"));
    }
}
