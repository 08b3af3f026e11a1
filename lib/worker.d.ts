import type { TrackerSettings, BackgroundSettings, DetectionLists, Shapes, OfflineOutput, Records } from './pkg/shapetrack.js';

/** How the worker's tracker starts. */
export interface TrackerWorkerOptions {
  /** Tracker settings over a preset (`{ preset: 'masks' }` for masks with frames). */
  tracker?: TrackerSettings;
  /** Keep what the offline pass needs, so `finish()` can re-link broken tracks. */
  offline?: boolean;
  /** Frame rate of the video (offline pass; default 25). */
  fps?: number;
  /** `'background'` (default): the adaptive background subtractor runs on each frame; `'none'`: pass detections to `track()`. */
  detector?: 'background' | 'none';
  /** Background subtractor settings. */
  background?: BackgroundSettings;
  /** Where the .wasm is, when not next to the package's files. */
  wasm?: URL | string;
}

/** The tracker in a Web Worker: every call is a message; the page stays responsive. */
export class TrackerWorker {
  /** Starts a worker and a tracker in it; rejects (and stops that worker) when the options are refused. */
  static start(options?: TrackerWorkerOptions): Promise<TrackerWorker>;
  private constructor(worker: Worker);
  /** Tracks the next frame (an ImageBitmap is transferred and closed; ImageData is copied). */
  track(image: ImageData | ImageBitmap | { width: number; height: number; data: Uint8ClampedArray | Uint8Array }, detections?: DetectionLists): Promise<Shapes>;
  /** The offline pass (started with `offline: true`). */
  finish(): Promise<OfflineOutput>;
  /** Every shape reported so far. */
  tracks(): Promise<Records>;
  /** Stops the worker; pending requests fail. */
  terminate(): void;
}
