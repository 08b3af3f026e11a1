#!/usr/bin/env node
// Builds the Rust core for the browser: a size-optimised wasm32 build of the library, then
// wasm-bindgen's ES-module glue and TypeScript types into www/pkg (ignored by git: the app
// always consumes a fresh build, never a committed one), then binaryen's wasm-opt over the
// module. Prints the raw and gzipped sizes.
//
//   node scripts/build-wasm.mjs              release build
//   node scripts/build-wasm.mjs --debug      debug build (faster to compile, slow to run)
//   node scripts/build-wasm.mjs --profiling  the release build again with its function names
//                                            kept, into target/pkg-profiling (www/pkg untouched)
//
// Profile the profiling build, never a module left out of wasm-opt: wasm-opt inlines small
// functions such as the `fminf` libcall behind `f32::min`, so a profile of wasm-bindgen's raw
// output shows costs the shipped module does not have (an eighth of the 1920×1080 detector's
// time once: removing that call changed nothing in the shipped build). For example:
//   node scripts/build-wasm.mjs --profiling
//   node --cpu-prof scripts/bench-wasm.mjs --scene demo --pkg target/pkg-profiling

import { existsSync, readFileSync, renameSync, statSync } from 'node:fs';
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

export function buildWasm({ debug = false, profiling = false } = {}) {
  // `wasm-release` (Cargo.toml): opt-level 3, fat LTO, one codegen unit; SIMD from
  // .cargo/config.toml. The browser module has a size budget (tests/e2e/labelling.test.mjs).
  const profile = debug ? 'debug' : 'wasm-release';
  run('cargo', [
    'build',
    '--lib',
    ...(debug ? [] : ['--profile', 'wasm-release']),
    '--target',
    'wasm32-unknown-unknown',
    '--no-default-features',
  ]);
  const target = process.env.CARGO_TARGET_DIR ? resolve(ROOT, process.env.CARGO_TARGET_DIR) : join(ROOT, 'target');
  const input = join(target, 'wasm32-unknown-unknown', profile, 'shapetrack.wasm');
  const pkg = profiling ? join(target, 'pkg-profiling') : PKG;
  const out = join(pkg, 'shapetrack_bg.wasm');
  // wasm-bindgen is the slow part of an unchanged rebuild; skip it when its output is newer.
  if (!existsSync(out) || statSync(out).mtimeMs < statSync(input).mtimeMs) {
    run('wasm-bindgen', ['--target', 'web', ...(profiling ? ['--keep-debug'] : []), '--out-dir', pkg, input]);
    if (!debug) {
      // Binaryen's optimiser from npm (devDependency `binaryen`; never Debian's wasm-opt 108,
      // whose output fails at init): smaller and a little faster on top of LLVM's output. The
      // features are those the module uses (SIMD: .cargo/config.toml).
      const wasmOpt = join(ROOT, 'node_modules', '.bin', 'wasm-opt');
      if (!existsSync(wasmOpt)) throw new Error(`${wasmOpt} missing: run npm ci`);
      const tmp = `${out}.opt`;
      run(wasmOpt, [
        '-O3',
        '--enable-bulk-memory',
        '--enable-nontrapping-float-to-int',
        '--enable-sign-ext',
        '--enable-mutable-globals',
        '--enable-simd',
        // The same optimisation with the name section kept (`-g`), for profilers.
        ...(profiling ? ['-g'] : []),
        out,
        '-o',
        tmp,
      ]);
      renameSync(tmp, out);
    }
  }
  const { raw, gzip } = wasmSize(out);
  console.log(
    `wasm: ${(raw / 1024).toFixed(0)} KiB raw, ${(gzip / 1024).toFixed(0)} KiB gzipped (${profile})`,
  );
}

if (process.argv[1] === fileURLToPath(import.meta.url)) {
  try {
    buildWasm({
      debug: process.argv.includes('--debug'),
      profiling: process.argv.includes('--profiling'),
    });
  } catch (e) {
    console.error(`build-wasm failed: ${e instanceof Error ? e.message : e}`);
    process.exit(1);
  }
}
