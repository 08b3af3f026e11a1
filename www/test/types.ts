// Type-checked (never run) against the .d.ts that wasm-bindgen and tsify generate from the Rust
// bindings: `tsc -p www/test/tsconfig.json`. The @ts-expect-error lines make the check two-sided:
// if the generated types became `any` or lost a field, those lines would stop erroring and tsc
// would fail.

import init, {
  FrameBuffer,
  decodeMask,
  encodeMask,
  parseRecords,
  version,
  writeRecords,
  type Format,
  type MaskBitmap,
  type RecordJs,
  type Records,
  type RleJs,
} from '../pkg/shapetrack.js';

export async function usage(): Promise<string> {
  const wasm = await init();
  const buf = new FrameBuffer(64, 48);
  const view: Uint8ClampedArray = new Uint8ClampedArray(wasm.memory.buffer, buf.ptr(), buf.len());
  view.fill(255);
  const size: [number, number] = [buf.width, buf.height];

  const fmt: Format = 'mot';
  const recs: Records = parseRecords(fmt, '1,1,0,0,1,1\n', 'x.txt');
  const first: RecordJs | undefined = recs[0];
  const id: number = first?.id ?? -1;
  const mask: RleJs | undefined = first?.mask;
  const text: string = writeRecords('mots', recs);

  const rle: RleJs = encodeMask(4, 4, new Uint8Array(16));
  const bm: MaskBitmap = decodeMask(rle);
  const data: Uint8Array = bm.data;

  // @ts-expect-error: formats are a closed set
  parseRecords('yaml', '', '');
  // @ts-expect-error: a record needs a box
  writeRecords('mot', [{ frame: 1, id: 1 }]);
  // @ts-expect-error: RLE size is [height, width]
  decodeMask({ size: [1], counts: '' });
  // @ts-expect-error: mask bitmaps are Uint8Array, not number[]
  const wrong: number[] = bm.data;

  buf.free();
  return `${version()} ${size} ${id} ${mask?.counts} ${text} ${data.length} ${wrong}`;
}
