// SPDX-License-Identifier: MIT
// stb_image compiled into the fuzz targets, so that the decoder itself carries coverage and sanitizer
// instrumentation (the Debian libstb.so is not instrumented; these definitions take precedence over it).
#define STB_IMAGE_IMPLEMENTATION
#include <stb_image.h>
