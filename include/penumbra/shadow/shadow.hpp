#pragma once

// Everything of penumbra::shadow (CPU shadow math and the GPU structs it fills).

#include <penumbra/shadow/cascades.hpp>
#include <penumbra/shadow/gpu_types.hpp>
#include <penumbra/shadow/local_lights.hpp>
#include <penumbra/shadow/math.hpp>
#include <penumbra/shadow/pack.hpp>
#include <penumbra/shadow/types.hpp>
