#!/usr/bin/env node
// How many tracks the app keeps on one object (issue 66: "two ids on one person"): each DAVIS
// clip named is opened in the app (headless Chromium, www/dist) as an image sequence with the
// detector named, played through at full speed; per frame, the tracker's records whose box
// lies with at least 60 % of its area on the ground truth's box are counted. Prints, per clip,
// the frames with two or more such tracks and every id:class seen on the object with its
// frame count. A measurement, not a test (tests/e2e/ssd.test.mjs asserts the tennis case).
//
//   npm run build && node scripts/tracks-on-object.mjs [DETECTOR] [clip,clip,...]
//     DETECTOR: an app detector (default moving-ssd); clips from ../shared/data's davis2016-moving,
//     davis2016-more and davis-car-shadow (default hike,rollerblade,tennis,kite-walk,dance-jump,scooter-black)

import { readdirSync, readFileSync } from 'node:fs';
import { join } from 'node:path';
import { launch, serve, DIST, ROOT } from '../tests/e2e/harness.mjs';
const det = process.argv[2] ?? 'moving-ssd';
const clips = (process.argv[3] ?? 'hike,rollerblade,tennis,kite-walk,dance-jump,scooter-black').split(',');
const server = await serve(DIST, Number(process.env.PORT ?? 47498));
const b = await launch();
for (const clip of clips) {
  const set = clip === 'car-shadow' ? 'davis-car-shadow' : ['hike','scooter-black','soapbox','bmx-trees','bus','camel','car-roundabout','dog'].includes(clip) ? 'davis2016-moving' : 'davis2016-more';
  const D = join(ROOT, '..', 'shared', 'data', set, 'DAVIS');
  const files = readdirSync(join(D, 'JPEGImages/480p', clip)).filter((f) => f.endsWith('.jpg')).sort().map((f) => join(D, 'JPEGImages/480p', clip, f));
  const pngs = readdirSync(join(D, 'Annotations/480p', clip)).filter((f) => f.endsWith('.png')).sort().map((f) => readFileSync(join(D, 'Annotations/480p', clip, f)).toString('base64'));
  const page = await b.context.newPage();
  await page.goto(`${server.url}?demo=0&speed=max`);
  await page.waitForFunction(() => !!window.__shapetrack);
  await page.selectOption('#detector', det);
  await page.setInputFiles('#file-images', files);
  await page.waitForFunction(() => window.__shapetrack.state().processed >= 1, undefined, { timeout: 120000 });
  await page.evaluate(() => document.activeElement?.blur());
  await page.keyboard.press('Space');
  await page.waitForFunction((n) => window.__shapetrack.state().processed === n, files.length, { timeout: 600000 });
  const res = await page.evaluate(async (pngs) => {
    const recs = window.__shapetrack.records();
    const out = [];
    for (let i = 0; i < pngs.length; i++) {
      const bytes = Uint8Array.from(atob(pngs[i]), (c) => c.charCodeAt(0));
      const bmp = await createImageBitmap(new Blob([bytes], { type: 'image/png' }));
      const ctx = new OffscreenCanvas(bmp.width, bmp.height).getContext('2d');
      ctx.drawImage(bmp, 0, 0);
      const { data, width, height } = ctx.getImageData(0, 0, bmp.width, bmp.height);
      let [x0, y0, x1, y1] = [1e9, 1e9, -1, -1];
      for (let y = 0; y < height; y++) for (let x = 0; x < width; x++) if (data[4 * (y * width + x)] > 127) { x0 = Math.min(x0, x); x1 = Math.max(x1, x); y0 = Math.min(y0, y); y1 = Math.max(y1, y); }
      const g = { x: x0, y: y0, w: x1 - x0 + 1, h: y1 - y0 + 1 };
      const on = recs.filter((r) => r.frame === i + 1).filter((r) => {
        const iw = Math.min(r.bbox.x + r.bbox.w, g.x + g.w) - Math.max(r.bbox.x, g.x);
        const ih = Math.min(r.bbox.y + r.bbox.h, g.y + g.h) - Math.max(r.bbox.y, g.y);
        if (iw <= 0 || ih <= 0) return false;
        return (iw * ih) / (r.bbox.w * r.bbox.h) >= 0.6; // the record lies mostly on the object
      });
      out.push(on.map((r) => `${r.id}:${r.class}`));
    }
    return out;
  }, pngs);
  const ids = new Map();
  let multi = 0;
  res.forEach((on) => { if (on.length > 1) multi++; for (const k of on) ids.set(k, (ids.get(k) ?? 0) + 1); });
  console.log(`${det} ${clip} (${files.length} frames): frames with 2+ tracks on the object ${multi}; ids on it ${JSON.stringify([...ids])}`);
  await page.close();
}
await b.close();
process.exit(0);
