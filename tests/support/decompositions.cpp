#include "support/decompositions.hpp"

template class Eigen::JacobiSVD<Eigen::MatrixXd>;
template class Eigen::JacobiSVD<chasles::Matrix6Xd>;
