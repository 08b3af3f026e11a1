// Frame sources on the page side: a video file, an image sequence, the webcam. Each gives
// frames as ImageBitmaps by 1-based frame number (the synthetic demo is rendered in the
// worker instead, see ../worker/worker.js).

/**
 * @typedef {{
 *   kind: 'video' | 'images' | 'webcam',
 *   name: string,
 *   width: number,
 *   height: number,
 *   frames: number | null,
 *   fps: number,
 *   frameAt: (n: number) => Promise<ImageBitmap | null>,
 *   close: () => void,
 * }} Source  `frames` is null for a live source; `frameAt` gives null for a frame that is not
 *   available (a webcam frame older than the kept history)
 */

/** Common frame rates; a measured rate snaps to the nearest when close. */
const RATES = [23.976, 24, 25, 29.97, 30, 48, 50, 59.94, 60];

/** @param {number} fps */
export function snapFps(fps) {
  let best = fps;
  let err = Infinity;
  for (const r of RATES) {
    const e = Math.abs(r - fps) / r;
    if (e < err) {
      err = e;
      best = r;
    }
  }
  return err < 0.03 ? best : Math.round(fps * 1000) / 1000;
}

/**
 * @param {HTMLVideoElement} video
 * @param {string} type
 * @param {number} [timeoutMs]
 */
function once(video, type, timeoutMs = 10000) {
  return new Promise((resolve, reject) => {
    const t = setTimeout(() => reject(new Error(`video: no "${type}" after ${timeoutMs} ms`)), timeoutMs);
    video.addEventListener(
      type,
      () => {
        clearTimeout(t);
        resolve(undefined);
      },
      { once: true },
    );
  });
}

/**
 * Resolves once the video presents its next frame (requestVideoFrameCallback), or after
 * `timeoutMs`, or at once where the browser lacks the callback.
 * @param {HTMLVideoElement} video
 * @param {number} timeoutMs
 * @returns {Promise<void>}
 */
function framePresented(video, timeoutMs) {
  if (!('requestVideoFrameCallback' in video)) return Promise.resolve();
  return new Promise((resolve) => {
    const handle = video.requestVideoFrameCallback(() => {
      clearTimeout(timer);
      resolve();
    });
    const timer = setTimeout(() => {
      video.cancelVideoFrameCallback(handle);
      resolve();
    }, timeoutMs);
  });
}

/**
 * The frame rate of a video, from the media times of a few decoded frames (browsers do not
 * expose it). Falls back to 25 when the browser lacks requestVideoFrameCallback.
 * @param {HTMLVideoElement} video
 */
async function measureFps(video) {
  if (!('requestVideoFrameCallback' in video)) return 25;
  /** @type {number[]} */
  const times = [];
  const done = new Promise((resolve) => {
    /** @type {VideoFrameRequestCallback} */
    const cb = (_now, meta) => {
      times.push(meta.mediaTime);
      if (times.length < 8) video.requestVideoFrameCallback(cb);
      else resolve(undefined);
    };
    video.requestVideoFrameCallback(cb);
  });
  video.playbackRate = 1;
  await video.play();
  await Promise.race([done, new Promise((r) => setTimeout(r, 1500))]);
  video.pause();
  const d = [];
  for (let i = 1; i < times.length; i++) if (times[i] > times[i - 1]) d.push(times[i] - times[i - 1]);
  d.sort((a, b) => a - b);
  return d.length ? snapFps(1 / d[Math.floor(d.length / 2)]) : 25;
}

/**
 * A video file, read frame by frame by seeking (exact frames, in order or not).
 * @param {HTMLVideoElement} video
 * @param {File} file
 * @returns {Promise<Source>}
 */
export async function videoSource(video, file) {
  const url = URL.createObjectURL(file);
  video.src = url;
  await once(video, 'loadedmetadata');
  const fps = await measureFps(video);
  const frames = Math.max(1, Math.floor(video.duration * fps + 1e-6));
  return {
    kind: 'video',
    name: file.name,
    width: video.videoWidth,
    height: video.videoHeight,
    frames,
    fps,
    async frameAt(n) {
      // Aim at the middle of the frame's display interval so rounding never lands on its
      // neighbour.
      const t = (n - 0.5) / fps;
      if (Math.abs(video.currentTime - t) > 1e-4) {
        // 'seeked' says the position changed, not that the sought frame reached the
        // compositor: on a busy machine Chromium can still hand createImageBitmap the frame
        // shown before the seek (a backward follow then saw one picture over and over). The
        // video-frame callback fires once the new frame is presented; the timeout keeps a
        // browser that skips it for a paused, hidden element from stalling. 2 s, not 500 ms:
        // beside a Rust build a backward follow in the e2e suite once saw frame 16 on every
        // frame again (the presentation, it seems, came after 500 ms). The price is a
        // display frame per seek (headless Chromium: ~16.7 ms against ~4 ms), so a video file
        // is read at up to ~60 frames a second: wrong pixels are worse than a slower read.
        const presented = framePresented(video, 2000);
        const seeked = once(video, 'seeked');
        video.currentTime = t;
        await seeked;
        await presented;
      }
      return createImageBitmap(video);
    },
    close() {
      video.removeAttribute('src');
      video.load();
      URL.revokeObjectURL(url);
    },
  };
}

/**
 * A name for an image sequence, used for exports: its folder when the browser says (a folder
 * pick), else what its file names share before the frame number (`frame_0001.png` …
 * `frame_0100.png` → `frame`), else `images` — never the first file's name, which would call
 * the exports `00000.mot.txt`.
 * @param {string[]} names file names, in order
 * @param {string} [dir] the folder, when known
 * @returns {string}
 */
export function sequenceName(names, dir) {
  if (dir) return dir;
  const stems = names.map((n) => n.replace(/\.[^.]*$/, ''));
  let prefix = stems[0] ?? '';
  for (const s of stems) {
    let k = 0;
    while (k < prefix.length && k < s.length && prefix[k] === s[k]) k++;
    prefix = prefix.slice(0, k);
  }
  // The shared part may end inside the frame number (`frame_00` of `frame_0001`): cut back to
  // before it, and drop the separators.
  const name = prefix.replace(/\d+$/, '').replace(/[\s._-]+$/, '');
  return name || 'images';
}

/** Natural order: frame2.jpg before frame10.jpg. */
const collator = new Intl.Collator(undefined, { numeric: true, sensitivity: 'base' });

/**
 * An image sequence (a MOTChallenge img1/ folder, a DAVIS sequence, ...), in file-name order.
 * @param {File[]} files
 * @param {number} [fps]
 * @returns {Promise<Source>}
 */
export async function imageSource(files, fps = 25) {
  const list = [...files].filter((f) => f.type.startsWith('image/')).sort((a, b) => collator.compare(a.name, b.name));
  if (!list.length) throw new Error('no image files selected');
  const first = await createImageBitmap(list[0]);
  const { width, height } = first;
  first.close();
  const dir = list[0].webkitRelativePath?.split('/')[0];
  return {
    kind: 'images',
    name: sequenceName(
      list.map((f) => f.name),
      dir,
    ),
    width,
    height,
    frames: list.length,
    fps,
    frameAt: (n) => (n >= 1 && n <= list.length ? createImageBitmap(list[n - 1]) : Promise.resolve(null)),
    close() {},
  };
}

/**
 * The webcam. Frames are numbered as they are grabbed; the last `keep` are kept for stepping
 * back.
 * @param {HTMLVideoElement} video
 * @param {number} [keep]
 * @returns {Promise<Source & { grab: () => Promise<{ n: number, bitmap: ImageBitmap }> }>}
 */
export async function webcamSource(video, keep = 120) {
  const stream = await navigator.mediaDevices.getUserMedia({ video: { width: { ideal: 1280 }, height: { ideal: 720 } }, audio: false });
  video.srcObject = stream;
  await video.play();
  /** @type {Map<number, ImageBitmap>} */
  const history = new Map();
  let count = 0;
  const settings = stream.getVideoTracks()[0]?.getSettings() ?? {};
  return {
    kind: 'webcam',
    name: 'webcam',
    width: video.videoWidth,
    height: video.videoHeight,
    frames: null,
    fps: settings.frameRate ?? 30,
    async grab() {
      const bitmap = await createImageBitmap(video);
      const n = ++count;
      history.set(n, await createImageBitmap(bitmap));
      history.get(n - keep)?.close();
      history.delete(n - keep);
      return { n, bitmap };
    },
    async frameAt(n) {
      const b = history.get(n);
      return b ? createImageBitmap(b) : null;
    },
    close() {
      for (const t of stream.getTracks()) t.stop();
      for (const b of history.values()) b.close();
      history.clear();
      video.srcObject = null;
    },
  };
}
