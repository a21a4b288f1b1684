// Shared by every kernel: constants and the switches a pipeline is specialised with.
// Conventions (docs/design.md §2): local frame n = +z, t = +x, b = +y; wi points to the light,
// wo to the viewer; f is in 1/sr and excludes the cosine.
#ifndef LOBE_COMMON_GLSL
#define LOBE_COMMON_GLSL

const float PI = 3.14159265358979323846;
const float INV_PI = 0.31830988618379067154;

// Specialization constant 0: the white furnace replaces every Fresnel factor that multiplies a
// specular lobe by 1 (docs/design.md §3). A constant, not a uniform, so the unused branch is
// compiled out.
layout(constant_id = 0) const bool WHITE_FURNACE = false;

// Specialization constant 10: evaluate cos^n lobes with GLSL's plain pow(cos, n) instead of the
// careful exp(n log1m(s)) (brdf/terms.glsl). Only `lobe tradeoff` turns it on, to measure the trade.
layout(constant_id = 10) const bool FAST_POW = false;

#endif
