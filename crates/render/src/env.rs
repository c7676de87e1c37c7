//! Environment maps: loading (EXR, Radiance HDR), the built-in procedural default, and importance sampling.
