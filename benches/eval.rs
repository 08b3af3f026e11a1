//! Evaluating all 11 MOT15-train sequences for one tracker (SORT baseline): parsing excluded
//! (`evaluate`, from records) and included (`files`, layout discovery + parsing + evaluate).

use criterion::{criterion_group, criterion_main, Criterion};
use shapetrack::eval::{evaluate, EvalConfig, SequenceInput};
use shapetrack::io::layout::{discover, load_sequence, Format};
use std::hint::black_box;
use std::path::{Path, PathBuf};

fn data() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data")
}

fn load(gt: &Path, res: &Path) -> Vec<SequenceInput> {
    let layout = discover(gt, "MOT15", "train").expect("mot15-train layout");
    layout
        .sequences
        .iter()
        .map(|e| load_sequence(e, res, Format::Mot, false).expect("sequence"))
        .collect()
}

fn bench(c: &mut Criterion) {
    let gt = data().join("mot15-train");
    let res = data().join("mot15-train-baselines/rf_sort/data");
    let inputs = load(&gt, &res);
    let config = EvalConfig::for_benchmark("MOT15", false);
    let mut g = c.benchmark_group("mot15_train_rf_sort");
    g.sample_size(20);
    g.bench_function("evaluate", |b| {
        b.iter(|| evaluate(black_box(&inputs), &config).expect("evaluate"))
    });
    g.bench_function("files", |b| {
        b.iter(|| evaluate(&load(black_box(&gt), &res), &config).expect("evaluate"))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
