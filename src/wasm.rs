//! wasm bindings (work in progress).
