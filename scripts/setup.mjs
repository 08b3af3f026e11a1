#!/usr/bin/env node
// Installs what `npm start` / `npm test` need on a fresh machine, skipping every step that is
// already done, so running it twice costs a few version checks. Uses only Node built-ins: it
// runs before `node_modules` exists.
//
//   node scripts/setup.mjs          npm deps, the wasm32 target, wasm-bindgen-cli
//   node scripts/setup.mjs --e2e    also Debian's chromium for the Playwright suite
//   node scripts/setup.mjs --python also the Python venv of the package's tests (PYVENV; `npm test`
//                                   makes it whenever its `python package` step runs)

import { execFileSync, spawnSync } from 'node:child_process';
import { existsSync, statSync } from 'node:fs';
import { homedir } from 'node:os';
import { dirname, join } from 'node:path';
import { fileURLToPath } from 'node:url';

export const ROOT = join(dirname(fileURLToPath(import.meta.url)), '..');
export const WASM_BINDGEN_VERSION = '0.2.130';
export const CHROMIUM = '/usr/bin/chromium';

/** Runs a command with inherited stdio; throws on a non-zero exit. */
export function run(cmd, args, opts = {}) {
  console.log(`$ ${cmd} ${args.join(' ')}`);
  const r = spawnSync(cmd, args, { stdio: 'inherit', cwd: ROOT, ...opts });
  if (r.error) throw r.error;
  if (r.status !== 0) throw new Error(`${cmd} ${args.join(' ')} exited with ${r.status}`);
}

/** The trimmed stdout of a command, or null when it is missing or fails. */
function output(cmd, args) {
  try {
    return execFileSync(cmd, args, { encoding: 'utf8', stdio: ['ignore', 'pipe', 'ignore'] }).trim();
  } catch {
    return null;
  }
}

function npmDeps() {
  const marker = join(ROOT, 'node_modules', '.package-lock.json');
  const lock = join(ROOT, 'package-lock.json');
  // npm writes node_modules/.package-lock.json on every install: newer than the lockfile means
  // the tree matches it.
  if (existsSync(marker) && statSync(marker).mtimeMs >= statSync(lock).mtimeMs) return;
  run('npm', ['ci', '--no-audit', '--no-fund']);
}

function wasmTarget() {
  const installed = output('rustup', ['target', 'list', '--installed']) ?? '';
  if (installed.split('\n').includes('wasm32-unknown-unknown')) return;
  run('rustup', ['target', 'add', 'wasm32-unknown-unknown']);
}

function rustComponents() {
  // `npm test` runs cargo fmt and clippy; a minimal rustup profile lacks them.
  const have = output('rustup', ['component', 'list', '--installed']) ?? '';
  const missing = ['clippy', 'rustfmt'].filter((c) => !have.split('\n').some((l) => l.startsWith(c)));
  if (missing.length) run('rustup', ['component', 'add', ...missing]);
}

function wasmBindgen() {
  const v = output('wasm-bindgen', ['--version']) ?? '';
  if (v.includes(WASM_BINDGEN_VERSION)) return;
  // The CLI must equal the `wasm-bindgen` crate version pinned in Cargo.toml.
  run('cargo', ['install', 'wasm-bindgen-cli', '--version', WASM_BINDGEN_VERSION]);
}

function chromium() {
  if (existsSync(CHROMIUM)) return;
  const sudo = process.getuid && process.getuid() !== 0 ? ['sudo'] : [];
  const apt = (args) =>
    sudo.length ? run('sudo', ['apt-get', ...args]) : run('apt-get', args);
  apt(['update']);
  apt(['install', '-y', 'chromium']);
}

// The Python package's tests (python/, issue 67) run in a venv outside the clone, so no
// install ever touches the system Python and a fresh clone reuses it. Its packages are what
// the tests import: maturin builds the extension (`pip install --no-build-isolation`, so no
// download at build time), numpy and supervision for the API, ray and fsspec for the batch
// runs, tqdm for their progress bar, pytest to run them.
export const PYVENV = process.env.SHAPETRACK_PYVENV ?? join(homedir(), '.cache', 'shapetrack', 'pyvenv');
export const PYTHON = join(PYVENV, 'bin', 'python');
const PY_PACKAGES = ['maturin>=1.5,<2', 'numpy', 'supervision', 'ray', 'fsspec', 'tqdm', 'pytest'];

export function pythonEnv() {
  if (!existsSync(PYTHON)) run('python3', ['-m', 'venv', PYVENV]);
  // One import of everything (plus maturin's version) says whether the venv is complete.
  const probe = 'import numpy, supervision, ray, fsspec, tqdm, pytest, maturin';
  if (output(PYTHON, ['-c', probe]) !== null) return;
  run(PYTHON, ['-m', 'pip', 'install', '--quiet', '--disable-pip-version-check', ...PY_PACKAGES]);
}

export function setup({ e2e = false, python = false } = {}) {
  npmDeps();
  wasmTarget();
  rustComponents();
  wasmBindgen();
  if (e2e) chromium();
  if (python) pythonEnv();
}

if (process.argv[1] === fileURLToPath(import.meta.url)) {
  try {
    setup({ e2e: process.argv.includes('--e2e'), python: process.argv.includes('--python') });
  } catch (e) {
    console.error(`setup failed: ${e instanceof Error ? e.message : e}`);
    process.exit(1);
  }
}
