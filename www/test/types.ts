// Type-checked (never run) against the .d.ts that wasm-bindgen and tsify generate from the Rust
// bindings: `tsc -p www/test/tsconfig.json`. The @ts-expect-error lines make the check two-sided:
// if the generated types became `any` or lost a field, those lines would stop erroring and tsc
// would fail.

import init, {
  BackgroundDetector,
  Detections,
  FrameBuffer,
  SynthScene,
  Tracker,
  evaluate,
  decodeMask,
  encodeMask,
  parseAnnotations,
  version,
  writeAnnotations,
  type Annotations,
  type Format,
  type JoinJs,
  type MaskBitmap,
  type OfflineSettings,
  type TrackConfig,
  type TrackerSettings,
  type OfflineOutput,
  type OfflineProgress,
  type RecordJs,
  type Records,
  type RleJs,
  type Scores,
  type ShapeJs,
  type Shapes,
} from '../pkg/shapetrack.js';

export async function usage(): Promise<string> {
  const wasm = await init();
  const buf = new FrameBuffer(64, 48);
  const view: Uint8ClampedArray = new Uint8ClampedArray(wasm.memory.buffer, buf.ptr(), buf.len());
  view.fill(255);
  const size: [number, number] = [buf.width, buf.height];

  const fmt: Format = 'mot';
  const parsed: Annotations = parseAnnotations(fmt, '1,1,0,0,1,1\n', 'x.txt');
  const recs: Records = parsed.records;
  const width: number | undefined = parsed.width;
  const first: RecordJs | undefined = recs[0];
  const id: number = first?.id ?? -1;
  const mask: RleJs | undefined = first?.mask;
  const text: string = writeAnnotations('cvat', recs, { width: 640, height: 480, labels: [{ class: -1, name: 'object' }] });
  // Formats with frame-relative boxes take the frame size when reading.
  const yolo: Annotations = parseAnnotations('yolo', text, 'x.txt', { width: 640, height: 480 });
  const studio: Format = 'label-studio';
  const scalabel: Format = 'scalabel';

  const rle: RleJs = encodeMask(4, 4, new Uint8Array(16));
  const bm: MaskBitmap = decodeMask(rle);
  const data: Uint8Array = bm.data;

  // @ts-expect-error: formats are a closed set
  parseAnnotations('yaml', '', '');
  // @ts-expect-error: a record needs a box
  writeAnnotations('mot', [{ frame: 1, id: 1 }]);
  // @ts-expect-error: sequence info has no such field
  writeAnnotations('mot', [], { fps: 25 });
  // @ts-expect-error: RLE size is [height, width]
  decodeMask({ size: [1], counts: '' });
  // @ts-expect-error: mask bitmaps are Uint8Array, not number[]
  const wrong: number[] = bm.data;

  // The demo pipeline: scene → detector → tracker → scores.
  const scene = new SynthScene('demo');
  const frameBuf = new FrameBuffer(scene.width, scene.height);
  const tracker = new Tracker({ max_lost: 60, terms: { iou: { weight: 1, gate: null } } });
  const bg = new BackgroundDetector({ threshold: 25, connectivity: 8 });
  const sf = scene.render(1, frameBuf);
  const dets: Detections = bg.detect(frameBuf);
  const n: number = dets.len + sf.detections().len;
  const shapes: Shapes = tracker.update(1, frameBuf, dets);
  const s0: ShapeJs | undefined = shapes[0];
  const state: 'tentative' | 'confirmed' | 'lost' | 'removed' | undefined = s0?.state;
  const own = Detections.fromLists({ boxes: [{ bbox: { x: 0, y: 0, w: 4, h: 4 }, score: 0.9 }] });
  tracker.updateDetections(2, own);
  const scores: Scores = evaluate(sf.groundTruth(), tracker.tracks(), 2, { similarity: 'mask' });
  const hota: number = scores.hota;
  // @ts-expect-error: unknown tracker options are type errors (and runtime errors)
  new Tracker({ max_lots: 3 });
  // The settings types are derived from the core's config (tsify), every field optional.
  const settings: TrackerSettings = { preset: 'masks', appearance: { lazy: true }, score_adaptation: null };
  const field: keyof TrackConfig = 'max_lost';
  // @ts-expect-error: presets are a closed set
  new Tracker({ preset: 'mask' });
  // @ts-expect-error: a nested field of the core's config keeps its type
  new Tracker({ terms: { iou: { weight: 'heavy' } } });
  // @ts-expect-error: similarity is box or mask
  evaluate(sf.groundTruth(), tracker.tracks(), 2, { similarity: 'area' });
  new Tracker(settings);
  // @ts-expect-error: scene presets are a closed set
  new SynthScene('forest');
  // @ts-expect-error: connectivity is 4 or 8
  new BackgroundDetector({ connectivity: 6 });

  // The offline pass: a tracker built with offline options, then finish() with progress.
  const opts: OfflineSettings = { fps: 25, relink: { solver: 'global', max_gap_seconds: 4 }, fill: { max_gap: 8, trajectory: 'linear' } };
  const offline = new Tracker({ max_lost: 30 }, opts);
  offline.update(1, frameBuf, dets);
  const canFinish: boolean = offline.offline && !offline.finished;
  const phases: Array<OfflineProgress['phase']> = [];
  const out: OfflineOutput = offline.finish((p) => {
    const f: number = p.fraction;
    phases.push(p.phase);
    if (f > 1) throw new Error('out of range');
  });
  offline.finish();
  const join: JoinJs | undefined = out.joins[0];
  const master: number = join?.master ?? 0;
  const filled: boolean = out.records.some((r) => r.interpolated === true) && out.filled >= 0;
  // @ts-expect-error: offline options need the frame rate
  new Tracker({}, { relink: {} });
  // @ts-expect-error: join solvers are a closed set
  new Tracker({}, { fps: 25, relink: { solver: 'fastest' } });
  // @ts-expect-error: unknown fill options are type errors
  new Tracker({}, { fps: 25, fill: { max_gaps: 3 } });
  // @ts-expect-error: the progress callback gets a progress report, not a number
  offline.finish((p: number) => p);
  // @ts-expect-error: phases are a closed set
  const phase: OfflineProgress['phase'] = 'tracking';

  buf.free();
  return `${field} ${n} ${state} ${hota} ${canFinish} ${phases} ${master} ${filled} ${phase} ` + `${version()} ${size} ${width} ${id} ${mask?.counts} ${text} ${data.length} ${wrong}`;
}
