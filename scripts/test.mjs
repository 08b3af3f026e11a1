#!/usr/bin/env node
// `npm test`: every test of the project, in one command, on a fresh machine.
//
// Installs what is missing (scripts/setup.mjs, each step skipped when done), then runs the Rust
// checks and tests (native and wasm), builds the app, and runs the JS unit tests, the type
// checks and the Playwright end-to-end suite. A failing step does not stop the independent
// ones; steps that need a failed build are skipped. Ends with one "N passed, N failed" line.
//
//   node scripts/test.mjs              everything
//   node scripts/test.mjs --only=e2e   steps whose name contains "e2e" (plus their builds)
//   node scripts/test.mjs --only=python   the Python package (python/) alone

import { spawnSync } from 'node:child_process';
import { readFileSync, readdirSync } from 'node:fs';
import { dirname, join } from 'node:path';
import { PYTHON, ROOT, setup } from './setup.mjs';
import { buildWasm } from './build-wasm.mjs';

const only = process.argv.find((a) => a.startsWith('--only='))?.slice('--only='.length);

/**
 * @typedef {{ name: string, needs?: string[], optIn?: boolean, run: () => void }} Step
 *   `optIn`: run only when `--only=` selects it
 */

/** @param {string} cmd @param {string[]} args @param {Record<string, string>} [env] */
function sh(cmd, args, env = {}) {
  console.log(`\n$ ${cmd} ${args.join(' ')}`);
  const r = spawnSync(cmd, args, { stdio: 'inherit', cwd: ROOT, env: { ...process.env, ...env } });
  if (r.error) throw r.error;
  if (r.status !== 0) throw new Error(`exit ${r.status}`);
}

const npx = (/** @type {string[]} */ args) => sh('npx', ['--no-install', ...args]);
const WASM = ['--target', 'wasm32-unknown-unknown', '--no-default-features'];

/** The integration tests that run in wasm: `--test NAME` for each tests/*.rs using wasm-bindgen-test. */
function wasmTests() {
  const dir = join(ROOT, 'tests');
  return readdirSync(dir)
    .filter((f) => f.endsWith('.rs') && readFileSync(join(dir, f), 'utf8').includes('wasm_bindgen_test'))
    .flatMap((f) => ['--test', f.slice(0, -3)]);
}

/** @type {Step[]} */
const steps = [
  // The Python package's venv only when its step runs (`--only=e2e` does not need it).
  { name: 'setup', run: () => setup({ e2e: true, python: want.has('python package') }) },
  { name: 'cargo fmt', needs: ['setup'], run: () => sh('cargo', ['fmt', '--all', '--check']) },
  // `--workspace`: the Python bindings crate (python/) too, in the same run as the core.
  { name: 'cargo clippy', needs: ['setup'], run: () => sh('cargo', ['clippy', '--workspace', '--all-targets', '--', '-D', 'warnings']) },
  {
    // src/wasm/ only exists for wasm32, so the native clippy run never sees it. Every target
    // `wasm-pack test --node` builds (lib, CLI, all tests, examples; benches use criterion,
    // which does not build for wasm32), so that command keeps compiling.
    name: 'cargo clippy wasm32',
    needs: ['setup'],
    run: () =>
      sh('cargo', ['clippy', '--target', 'wasm32-unknown-unknown', '--lib', '--bins', '--tests', '--examples', '--', '-D', 'warnings']),
  },
  // No file in src/ or www/src over 800 lines (scripts/check-layout.mjs).
  { name: 'source layout', run: () => sh('node', ['scripts/check-layout.mjs']) },
  {
    // The crate's docs build without a warning (broken intra-doc links included); its
    // top-level example runs as a doctest in `cargo test`.
    name: 'cargo doc',
    needs: ['setup'],
    run: () => sh('cargo', ['doc', '--no-deps', '--lib'], { RUSTDOCFLAGS: '-D warnings' }),
  },
  // In the `ci` profile: `test` under another name (Cargo.toml), so that the Python package's
  // extension can be built in it too and link these dependencies (see `python package`).
  { name: 'cargo test', needs: ['setup'], run: () => sh('cargo', ['test', '--profile', 'ci', '--no-fail-fast']) },
  {
    // The mutation fuzzer with overflow checks on (an overflow that wraps silently in release is
    // a finding), 100,000 executions per reader, the readers spread over the cores. In the
    // `cargo test` step's profile (`ci` = `test`: opt-level 2, overflow checks on), so it reuses
    // that build instead of a second full release build (~4 min on 2 cores); `cargo test`
    // itself runs it with 2,000. The long run (10^6 each) is in the README.
    name: 'fuzz parsers',
    needs: ['setup'],
    run: () => sh('cargo', ['test', '--profile', 'ci', '--test', 'fuzz_parsers'], { FUZZ_ITERS: '100000' }),
  },
  {
    // The Python package (python/, issue 67): built and installed into the venv setup made, then
    // its tests, which compare it with the CLI bit for bit on the MOT15 sequences, check the
    // supervision adapter and run the Ray batch locally (a corrupt det file, a rerun that
    // recomputes nothing).
    //
    // The CLI and the extension come from the `ci` profile (`test` under another name) that
    // `cargo test` has built above: the CLI is the binary it built for its integration tests
    // (target/ci/shapetrack; `cargo test --no-run` only confirms it is up to date), and the
    // extension is built in that profile with every dependency's features equal to the test
    // build's (python/Cargo.toml says how), so it links the artifacts `cargo test` compiled and
    // this step compiles only PyO3 and the bindings crate. The bit-for-bit comparison wants the
    // package and the CLI from one profile. (In release, from a cold clone, the two builds took
    // ~40 minutes.) Not `--profile test`: maturin runs `cargo rustc`, which builds a test
    // harness in that profile, not the module.
    name: 'python package',
    needs: ['setup'],
    run: () => {
      sh('cargo', ['test', '--profile', 'ci', '--no-run']);
      // The venv's bin/ first: the build backend runs the `maturin` executable by name.
      const PATH = `${dirname(PYTHON)}:${process.env.PATH}`;
      sh(
        PYTHON,
        ['-m', 'pip', 'install', '--quiet', '--disable-pip-version-check', '--no-build-isolation',
          '--config-settings=build-args=--profile ci', './python'],
        { PATH },
      );
      sh(PYTHON, ['-m', 'pytest', '-q', '-p', 'no:cacheprovider', 'python/tests'], {
        SHAPETRACK_CLI: join(ROOT, 'target', 'ci', 'shapetrack'),
      });
    },
  },
  { name: 'build wasm', needs: ['setup'], run: () => buildWasm() },
  {
    // In release (opt-level 3, like the native tests), not the browser build's size-optimised
    // `wasm-release` profile: its fat LTO would relink every test binary slowly.
    name: 'wasm-bindgen tests',
    needs: ['setup'],
    run: () =>
      sh('cargo', ['test', '--release', ...WASM, ...wasmTests()], {
        CARGO_TARGET_WASM32_UNKNOWN_UNKNOWN_RUNNER: 'wasm-bindgen-test-runner',
      }),
  },
  { name: 'build app', needs: ['build wasm'], run: () => npx(['vite', 'build', '--config', 'www/vite.config.js', '--logLevel', 'warn']) },
  { name: 'js unit tests', needs: ['setup'], run: () => sh('node', ['--test', 'www/test/']) },
  // The built package's JS API under hostile calls (Errors, never traps), in Node.
  { name: 'wasm api (node)', needs: ['build wasm'], run: () => sh('node', ['--test', 'tests/wasm-node/']) },
  // The npm library: packed, installed offline in an empty folder, its README example run there,
  // its types checked and its type docs (TypeDoc) built without a warning.
  { name: 'library package (node)', needs: ['build wasm'], run: () => sh('node', ['--test', 'tests/lib/']) },
  {
    name: 'js type check',
    needs: ['build wasm'],
    run: () => {
      npx(['tsc', '-p', 'www/tsconfig.json']);
      npx(['tsc', '-p', 'www/tsconfig.worker.json']);
      npx(['tsc', '-p', 'www/test/tsconfig.json']);
    },
  },
  { name: 'e2e', needs: ['build app'], run: () => sh('node', ['--test', '--test-concurrency=1', 'tests/e2e/']) },
];

/** Steps to run: the selected ones and everything they need. */
function selected() {
  if (!only) return new Set(steps.filter((s) => !s.optIn).map((s) => s.name));
  const want = new Set();
  const add = (/** @type {string} */ name) => {
    if (want.has(name)) return;
    want.add(name);
    for (const n of steps.find((s) => s.name === name)?.needs ?? []) add(n);
  };
  for (const s of steps) if (s.name.includes(only)) add(s.name);
  return want;
}

const want = selected();
/** @type {Map<string, 'passed' | 'failed' | 'skipped'>} */
const result = new Map();
for (const step of steps) {
  if (!want.has(step.name)) continue;
  const blocked = (step.needs ?? []).filter((n) => result.get(n) !== 'passed');
  if (blocked.length) {
    result.set(step.name, 'skipped');
    console.log(`\n=== ${step.name}: skipped (needs ${blocked.join(', ')})`);
    continue;
  }
  console.log(`\n=== ${step.name}`);
  const t0 = Date.now();
  try {
    step.run();
    result.set(step.name, 'passed');
    console.log(`=== ${step.name}: passed (${((Date.now() - t0) / 1000).toFixed(0)} s)`);
  } catch (e) {
    result.set(step.name, 'failed');
    console.log(`=== ${step.name}: FAILED (${e instanceof Error ? e.message : e})`);
  }
}

console.log('\nsummary:');
for (const [name, r] of result) console.log(`  ${r.padEnd(7)} ${name}`);
const count = (/** @type {string} */ r) => [...result.values()].filter((v) => v === r).length;
const failed = count('failed') + count('skipped');
console.log(`${count('passed')} passed, ${count('failed')} failed, ${count('skipped')} skipped`);
process.exit(failed ? 1 : 0);
