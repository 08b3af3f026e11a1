// Types of `virtual:shapetrack-ssd` (scripts/models.mjs): the URLs of the SSD model, its label
// list and the TFLite wasm runtime as this build serves them, and the three functions of
// @tensorflow/tfjs-tflite the detector uses. Written here, not taken from the package: its own
// declarations point at a module file the package does not ship (dist/tflite_web_api_client).

declare module 'virtual:shapetrack-ssd' {
  /** URL of the .tflite flatbuffer extracted from @mediapipe/objectron. */
  export const modelUrl: string;
  /** URL of the model's label list (line i = class i). */
  export const labelsUrl: string;
  /** URL of the folder holding tflite_web_api_cc{,_simd}.{js,wasm}. */
  export const runtimeUrl: string;

  export type TfliteDataType = 'int8' | 'uint8' | 'bool' | 'int16' | 'int32' | 'uint32' | 'float32' | 'float64';

  /** One model input or output; `data()` is a live view on the interpreter's tensor. */
  export interface TfliteTensorInfo {
    id: number;
    dataType: TfliteDataType;
    name: string;
    /** e.g. "1,300,300,3" */
    shape: string;
    data(): Int8Array | Uint8Array | Int16Array | Int32Array | Uint32Array | Float32Array | Float64Array;
  }

  /** The TFLite interpreter wrapped by tfjs-tflite's TFLiteModel. */
  export interface TfliteModelRunner {
    getInputs(): TfliteTensorInfo[];
    getOutputs(): TfliteTensorInfo[];
    infer(): boolean;
    cleanUp(): void;
  }

  export interface TfliteModel {
    /** Private in tfjs-tflite's types, public at run time (pinned version 0.0.1-alpha.10). */
    readonly modelRunner: TfliteModelRunner;
  }

  export function setWasmPath(path: string): void;
  export function getWasmFeatures(): Promise<{ simd: boolean; multiThreading: boolean }>;
  export function loadTFLiteModel(
    model: string | ArrayBuffer,
    options?: { numThreads?: number; enableProfiling?: boolean },
  ): Promise<TfliteModel>;
}
