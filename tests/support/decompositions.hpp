// The singular value decompositions the tests check against (condition numbers, pseudo-inverses),
// compiled once in the support library (decompositions.cpp) rather than in every test that uses
// them: JacobiSVD is seconds of compilation per file, and twenty under the sanitizers, where the CI's
// 20 minutes are spent. (Eigen's eigensolvers cost as much to compile once as the tests save.)
// Include this header wherever a test uses one of these types.
#pragma once

#include <Eigen/Core>
#include <Eigen/SVD>

#include "chasles/core/model/model.hpp"

extern template class Eigen::JacobiSVD<Eigen::MatrixXd>;
extern template class Eigen::JacobiSVD<chasles::Matrix6Xd>;
