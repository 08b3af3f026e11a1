#!/usr/bin/env node
// The layout rules a script can check (issue 68): no file in src/ or www/src/ over 800 lines (a
// file holds one idea; unit tests that inflate one go to a `*_tests.rs` sibling), and a README a
// newcomer reads in one sitting (≤ 12 KB; the measurements live in docs/benchmarks.md).
// Prints the offenders and exits 1; `npm test` runs it.
//
//   node scripts/check-layout.mjs [--max=800]

import { readdirSync, readFileSync } from 'node:fs';
import { join, relative } from 'node:path';
import { ROOT } from './setup.mjs';

const max = Number(process.argv.find((a) => a.startsWith('--max='))?.slice('--max='.length) ?? 800);
const ROOTS = ['src', join('www', 'src')];
const SOURCE = /\.(rs|js|mjs|ts)$/;

/** @param {string} dir @returns {string[]} */
function files(dir) {
  return readdirSync(dir, { withFileTypes: true }).flatMap((e) => {
    const p = join(dir, e.name);
    if (e.isDirectory()) return files(p);
    return SOURCE.test(e.name) && !e.name.endsWith('.d.ts') ? [p] : [];
  });
}

/** @param {string} text */
const lines = (text) => text.split('\n').length - (text.endsWith('\n') ? 1 : 0);

const long = ROOTS.flatMap((r) => files(join(ROOT, r)))
  .map((f) => ({ file: relative(ROOT, f), n: lines(readFileSync(f, 'utf8')) }))
  .filter((f) => f.n > max)
  .sort((a, b) => b.n - a.n);
const README_MAX = 12_000;
const readme = readFileSync(join(ROOT, 'README.md')).length;
if (readme > README_MAX) {
  console.error(`README.md is ${readme} bytes, over ${README_MAX}: move measurements to docs/benchmarks.md, history to CHANGELOG.md`);
  process.exitCode = 1;
}
if (long.length) {
  console.error(`${long.length} source file(s) over ${max} lines (split along a seam; tests to a sibling file):`);
  for (const f of long) console.error(`  ${String(f.n).padStart(5)}  ${f.file}`);
  process.exit(1);
}
if (!process.exitCode) console.log(`every source file in ${ROOTS.join(' and ')} is ≤ ${max} lines; README.md ${readme} bytes`);
