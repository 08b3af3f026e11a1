// The npm library: `npm run pack:lib -- DEST` writes exactly one shapetrack-<version>.tgz, the
// tarball installs into an empty folder with no network, the README's embedding (which is
// examples/embed-node.mjs, byte for byte) runs there by package name and exits 0, and the
// package's TypeScript types check for a consumer, and its type docs (TypeDoc) build without a warning.

import { test } from 'node:test';
import assert from 'node:assert/strict';
import { spawnSync } from 'node:child_process';
import { copyFileSync, mkdirSync, mkdtempSync, readFileSync, readdirSync, rmSync, writeFileSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import { fileURLToPath } from 'node:url';

const ROOT = fileURLToPath(new URL('../..', import.meta.url));
const VERSION = readFileSync(join(ROOT, 'Cargo.toml'), 'utf8').match(/^version\s*=\s*"([^"]+)"/m)?.[1];

/** @param {string} cmd @param {string[]} args @param {string} cwd */
function sh(cmd, args, cwd) {
  const r = spawnSync(cmd, args, { cwd, encoding: 'utf8' });
  if (r.error) throw r.error;
  return r;
}

const work = mkdtempSync(join(tmpdir(), 'shapetrack-lib-'));
process.on('exit', () => rmSync(work, { recursive: true, force: true }));

test('pack, install offline in an empty folder, run the README embedding, check the types', () => {
  const dest = join(work, 'dist');
  const pack = sh('npm', ['run', '-s', 'pack:lib', '--', dest], ROOT);
  assert.equal(pack.status, 0, pack.stderr);
  const files = readdirSync(dest);
  assert.deepEqual(files, [`shapetrack-${VERSION}.tgz`], 'exactly one tarball, named by version');
  const tgz = join(dest, files[0]);
  const listing = sh('tar', ['-tzf', tgz], work).stdout.split('\n');
  for (const f of ['index.js', 'index.d.ts', 'worker.js', 'worker.d.ts', 'tracker-worker.js', 'pkg/shapetrack.js', 'pkg/shapetrack_bg.wasm', 'package.json', 'README.md']) {
    assert.ok(listing.includes(`package/${f}`), `${f} is in the tarball`);
  }
  // The bindings' JS snippets (`inline_js`): shapetrack.js imports them.
  assert.ok(listing.some((f) => /^package\/pkg\/snippets\/.+\.js$/.test(f)), 'the wasm-bindgen snippets are in the tarball');
  assert.ok(!listing.some((f) => f.includes('node_modules') || f.includes('target/')), 'no build outputs besides the module');

  const app = join(work, 'app');
  mkdirSync(app);
  writeFileSync(join(app, 'package.json'), JSON.stringify({ name: 'embed-test', private: true, type: 'module' }));
  const install = sh('npm', ['install', '--offline', '--no-audit', '--no-fund', tgz], app);
  assert.equal(install.status, 0, install.stderr);
  copyFileSync(join(ROOT, 'examples', 'embed-node.mjs'), join(app, 'embed-node.mjs'));
  const run = sh(process.execPath, ['embed-node.mjs'], app);
  assert.equal(run.status, 0, run.stderr);
  const m = run.stdout.match(/^(\d+) frames: (\d+) tracks, (\d+) shapes/);
  assert.ok(m, run.stdout);
  assert.equal(Number(m[1]), 300);
  assert.ok(Number(m[2]) >= 3 && Number(m[3]) > 300, `the scene's objects were tracked: ${run.stdout}`);

  // A TypeScript consumer of both entry points, checked against the package's own types.
  writeFileSync(
    join(app, 'check.ts'),
    [
      "import { load, Tracker, FrameBuffer, writeRgba, type Shapes } from 'shapetrack';",
      "import { TrackerWorker } from 'shapetrack/worker';",
      'await load();',
      "const t = new Tracker({ preset: 'masks', min_hits: 3 });",
      'const b = new FrameBuffer(4, 4);',
      'writeRgba(b, new Uint8Array(64));',
      'export const n: number = t.frame;',
      "export const start: () => Promise<TrackerWorker> = () => TrackerWorker.start({ detector: 'none', fps: 30 });",
      'export type S = Shapes;',
      '',
    ].join('\n'),
  );
  const tsc = join(ROOT, 'node_modules', '.bin', 'tsc');
  const types = sh(tsc, ['--noEmit', '--strict', '--target', 'es2022', '--module', 'nodenext', '--moduleResolution', 'nodenext', '--lib', 'es2022,esnext.disposable,dom', 'check.ts'], app);
  assert.equal(types.status, 0, types.stdout + types.stderr);
  // And a wrong option is a type error, so the check above means something.
  writeFileSync(join(app, 'bad.ts'), "import { Tracker } from 'shapetrack';\nnew Tracker({ min_hits: 'three' });\n");
  const bad = sh(tsc, ['--noEmit', '--strict', '--target', 'es2022', '--module', 'nodenext', '--moduleResolution', 'nodenext', '--lib', 'es2022,esnext.disposable,dom', 'bad.ts'], app);
  assert.notEqual(bad.status, 0, 'a config field of the wrong type is rejected');

  // The package's type docs (TypeDoc over both entry points, as installed) build without a
  // warning: every {@link} resolves and every type a signature names is exported.
  const typedoc = join(ROOT, 'node_modules', '.bin', 'typedoc');
  const tdConfig = (/** @type {string[]} */ files) =>
    JSON.stringify({
      compilerOptions: { strict: true, target: 'es2022', module: 'nodenext', moduleResolution: 'nodenext', lib: ['es2022', 'esnext.disposable', 'dom'], noEmit: true },
      files,
    });
  const docArgs = (/** @type {string} */ config, /** @type {string[]} */ entries) => [
    '--tsconfig', config, ...entries.flatMap((e) => ['--entryPoints', e]), '--emit', 'none', '--treatWarningsAsErrors', '--disableSources',
  ];
  const entries = ['node_modules/shapetrack/index.d.ts', 'node_modules/shapetrack/worker.d.ts'];
  writeFileSync(join(app, 'tsconfig.docs.json'), tdConfig(entries));
  const docs = sh(typedoc, docArgs('tsconfig.docs.json', entries), app);
  assert.equal(docs.status, 0, docs.stdout + docs.stderr);
  // A broken link is a failure, so the check above means something.
  writeFileSync(join(app, 'broken.d.ts'), '/** See {@link NoSuchThing}. */\nexport declare function f(): void;\n');
  writeFileSync(join(app, 'tsconfig.broken.json'), tdConfig(['broken.d.ts']));
  const broken = sh(typedoc, docArgs('tsconfig.broken.json', ['broken.d.ts']), app);
  assert.notEqual(broken.status, 0, 'a broken {@link} fails the type docs');
});

test('the README shows the tested embedding, byte for byte', () => {
  const example = readFileSync(join(ROOT, 'examples', 'embed-node.mjs'), 'utf8');
  for (const readme of ['README.md', join('lib', 'README.md')]) {
    const text = readFileSync(join(ROOT, readme), 'utf8');
    assert.ok(text.includes('```js\n' + example + '```'), `${readme} shows examples/embed-node.mjs`);
  }
  assert.ok(example.trimEnd().split('\n').length <= 10, 'the embedding is ten lines');
});
