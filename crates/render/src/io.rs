//! Image output: linear radiance buffers, tone mapping, sRGB PNG and linear EXR files.
