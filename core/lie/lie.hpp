// The whole Lie-group layer: SO(3), SE(3) and screw axes.
#pragma once

#include "core/lie/axis.hpp"
#include "core/lie/screw.hpp"
#include "core/lie/jacobians.hpp"
#include "core/lie/se3.hpp"
#include "core/lie/sincos.hpp"
#include "core/lie/so3.hpp"
#include "core/lie/types.hpp"
