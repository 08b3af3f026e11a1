#!/usr/bin/env node
// Packs the npm library `shapetrack` from the same crate the app uses: builds the wasm core
// (scripts/build-wasm.mjs: size-optimised, wasm-opt), stages lib/ (the ES-module entry with
// `load()`, the Web Worker helper, their types, the README) with the wasm-bindgen output under
// pkg/, sets the version from Cargo.toml, and runs `npm pack`. Writes exactly one
// `shapetrack-<version>.tgz` into DEST and prints its path.
//
//   npm run pack:lib -- DEST

import { cpSync, existsSync, mkdirSync, readFileSync, readdirSync, rmSync, writeFileSync } from 'node:fs';
import { join, resolve } from 'node:path';
import { ROOT, run } from './setup.mjs';
import { PKG, buildWasm } from './build-wasm.mjs';

const dest = process.argv[2];
if (!dest) {
  console.error('usage: npm run pack:lib -- DEST');
  process.exit(2);
}
const out = resolve(process.cwd(), dest);

const version = readFileSync(join(ROOT, 'Cargo.toml'), 'utf8').match(/^version\s*=\s*"([^"]+)"/m)?.[1];
if (!version) throw new Error('no version in Cargo.toml');

if (!process.env.SHAPETRACK_SKIP_WASM_BUILD) buildWasm();
const stage = join(ROOT, 'target', 'lib-pack');
rmSync(stage, { recursive: true, force: true });
mkdirSync(join(stage, 'pkg'), { recursive: true });
const manifest = JSON.parse(readFileSync(join(ROOT, 'lib', 'package.json'), 'utf8'));
manifest.version = version;
for (const f of manifest.files) {
  const from = f.startsWith('pkg/') ? join(PKG, f.slice(4)) : join(ROOT, 'lib', f);
  if (!existsSync(from)) throw new Error(`${from} is missing (the package lists it)`);
  cpSync(from, join(stage, f), { recursive: true });
}
writeFileSync(join(stage, 'package.json'), `${JSON.stringify(manifest, null, 2)}\n`);

mkdirSync(out, { recursive: true });
const name = `shapetrack-${version}.tgz`;
rmSync(join(out, name), { force: true });
run('npm', ['pack', '--silent', '--pack-destination', out], { cwd: stage });
if (!readdirSync(out).includes(name)) throw new Error(`npm pack did not write ${name}`);
console.log(join(out, name));
