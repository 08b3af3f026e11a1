//! Statistics of the dense-crowd family (`SynthConfig::pedestrians`, issue 64) next to the
//! crowd it imitates (about 46 people a frame, median visibility 0.44, 1920×1080, 25 fps):
//! people in view per frame, visibility quantiles and histogram, the share of person-frames
//! fully hidden, the scene's own detections' misses by visibility and their gaps per person.
//! One JSON line per scene: the grid's three seeds, then the bench's 50, 100 and 200 people.
//!
//! ```text
//! cargo run --release --example pedestrian_stats
//! cargo run --release --example pedestrian_stats -- '{"walkway": [0.4, 0.7], ...}' 60
//! ```
//!
//! With arguments (for tuning the family): a JSON `CrowdConfig` replacing the family's and the
//! walkers alive at once; the grid's three seeds only.

use shapetrack::synth::{Family, SceneStats, SynthConfig, PEDESTRIANS};

/// The grid's seeds (`shapetrack::grid::SYNTH_SEEDS`; the grid is native only, this example
/// also builds for wasm32).
const SEEDS: [u64; 3] = [101, 102, 103];

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let tuned = match &args[..] {
        [crowd, alive, ..] => Some((serde_json::from_str(crowd)?, alive.parse::<u32>()?)),
        _ => None,
    };
    let mut scenes: Vec<(String, SynthConfig)> = SEEDS
        .iter()
        .map(|&s| {
            let cfg = match tuned {
                Some((crowd, alive)) => SynthConfig {
                    crowd: Some(crowd),
                    ..SynthConfig::pedestrians(s, alive)
                },
                None => SynthConfig::family(Family::Pedestrians, s),
            };
            (format!("pedestrians-s{s}"), cfg)
        })
        .collect();
    for people in [50, 100, 200].into_iter().filter(|_| tuned.is_none()) {
        // The bench's scenes: walkers alive at once scaled so that about `people` are in view.
        let alive = (people as f64 * PEDESTRIANS as f64 / 46.4).round() as u32;
        scenes.push((
            format!("bench-{people}"),
            SynthConfig {
                frames: 50,
                ..SynthConfig::pedestrians(7, alive)
            },
        ));
    }
    for (name, cfg) in scenes {
        let s = SceneStats::measure(&cfg)?;
        println!("{}", serde_json::json!({ "scene": name, "stats": s }));
    }
    Ok(())
}
