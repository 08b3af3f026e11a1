import { load, SynthScene, FrameBuffer, Tracker } from 'shapetrack';

await load();
const scene = new SynthScene('occlusion');
const frame = new FrameBuffer(scene.width, scene.height);
const tracker = new Tracker({ preset: 'masks' }, { fps: scene.fps });
for (let n = 1; n <= scene.frames; n++) tracker.update(n, frame, scene.render(n, frame).detections());
const { records, joins } = tracker.finish();
const ids = new Set(records.map((r) => r.id));
console.log(`${scene.frames} frames: ${ids.size} tracks, ${records.length} shapes, ${joins.length} joins`);
