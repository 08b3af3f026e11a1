// Refreshes the screenshots www/README.md shows: runs the e2e tests that take them (the app
// must be built: `npm run build`) and copies target/e2e/docs/*.jpg to www/docs/. The pictures
// are the suite's own, so the README shows what the tests saw.
//
//   node scripts/doc-shots.mjs

import { spawnSync } from 'node:child_process';
import { copyFileSync, mkdirSync, readdirSync } from 'node:fs';
import { join } from 'node:path';
import { ROOT, SHOTS } from '../tests/e2e/harness.mjs';

const tests = ['tests/e2e/labelling.test.mjs', 'tests/e2e/relink.test.mjs', 'tests/e2e/timeline.test.mjs', 'tests/e2e/follow.test.mjs'];
const run = spawnSync(process.execPath, ['--test', '--test-concurrency=1', ...tests], { cwd: ROOT, stdio: 'inherit' });
if (run.status !== 0) process.exit(run.status ?? 1);
const dest = join(ROOT, 'www', 'docs');
mkdirSync(dest, { recursive: true });
for (const f of readdirSync(SHOTS).filter((f) => f.endsWith('.jpg'))) {
  copyFileSync(join(SHOTS, f), join(dest, f));
  console.log(`www/docs/${f}`);
}
