#!/usr/bin/env node
// Builds the Rust core for the browser: a release wasm32 build of the library, then
// wasm-bindgen's ES-module glue and TypeScript types into www/pkg (ignored by git: the app
// always consumes a fresh build, never a committed one). Prints the raw and gzipped sizes.
//
//   node scripts/build-wasm.mjs           release build
//   node scripts/build-wasm.mjs --debug   debug build (faster to compile, slow to run)

import { existsSync, readFileSync, statSync } from 'node:fs';
import { join, resolve } from 'node:path';
import { gzipSync } from 'node:zlib';
import { fileURLToPath } from 'node:url';
import { ROOT, run } from './setup.mjs';

export const PKG = join(ROOT, 'www', 'pkg');
export const WASM = join(PKG, 'shapetrack_bg.wasm');

/** Raw and gzip -9 size of the built wasm, in bytes. */
export function wasmSize(file = WASM) {
  const bytes = readFileSync(file);
  return { raw: bytes.length, gzip: gzipSync(bytes, { level: 9 }).length };
}

export function buildWasm({ debug = false } = {}) {
  const profile = debug ? 'debug' : 'release';
  run('cargo', [
    'build',
    '--lib',
    ...(debug ? [] : ['--release']),
    '--target',
    'wasm32-unknown-unknown',
    '--no-default-features',
  ]);
  const target = process.env.CARGO_TARGET_DIR ? resolve(ROOT, process.env.CARGO_TARGET_DIR) : join(ROOT, 'target');
  const input = join(target, 'wasm32-unknown-unknown', profile, 'shapetrack.wasm');
  const out = join(PKG, 'shapetrack_bg.wasm');
  // wasm-bindgen is the slow part of an unchanged rebuild; skip it when its output is newer.
  if (!existsSync(out) || statSync(out).mtimeMs < statSync(input).mtimeMs) {
    run('wasm-bindgen', ['--target', 'web', '--out-dir', PKG, input]);
  }
  const { raw, gzip } = wasmSize(out);
  console.log(
    `wasm: ${(raw / 1024).toFixed(0)} KiB raw, ${(gzip / 1024).toFixed(0)} KiB gzipped (${profile})`,
  );
}

if (process.argv[1] === fileURLToPath(import.meta.url)) {
  try {
    buildWasm({ debug: process.argv.includes('--debug') });
  } catch (e) {
    console.error(`build-wasm failed: ${e instanceof Error ? e.message : e}`);
    process.exit(1);
  }
}
