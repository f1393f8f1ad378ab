// The whole Lie-group layer: SO(3), SE(3) and screw axes.
#pragma once

#include "chasles/core/lie/axis.hpp"
#include "chasles/core/lie/screw.hpp"
#include "chasles/core/lie/jacobians.hpp"
#include "chasles/core/lie/se3.hpp"
#include "chasles/core/lie/sincos.hpp"
#include "chasles/core/lie/so3.hpp"
#include "chasles/core/lie/types.hpp"
