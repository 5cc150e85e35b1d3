// What first-order lookups meet over a set of captures (the study of first_order_tree.h): the
// pairs they descend, their errors against exact references and their certified bounds, and
// the tolerances at which captures are cut from their texels.
#pragma once

#include <array>
#include <cstddef>
#include <functional>
#include <span>

#include "basis/core/color.h"
#include "basis/core/grid.h"
#include "basis/lighting/capture_set.h"
#include "basis/study/first_order_tree.h"

namespace basis {

// Lookups over n captures: pairs of blocks per lookup; over every capture and channel whose
// reference exceeds 1e-3 of the largest, the error and the certified bound in % of the
// reference, median and p99; and over every capture and channel, how many values lie farther
// from their reference than their bound.
struct FirstOrderLookupCounts {
  double pairs = 0;
  double error_median = 0, error_p99 = 0, bound_median = 0, bound_p99 = 0;
  std::size_t bound_failures = 0;
};
// lookup(k) is capture k's lookup and references[k] its exact value.
FirstOrderLookupCounts count_first_order_lookups(
    std::span<const Rgb> references,
    const std::function<FirstOrderConvolution(std::size_t)>& lookup);

// The absolute tolerances, per channel, at which capture2qt cuts a capture of these texels and
// lights at a relative `tolerance`: that share of the channel's mean, the lights' share (as if
// splatted) included.
std::array<double, 3> capture_tolerances(const Grid& texels,
                                         std::span<const DirectionalLight> lights,
                                         double tolerance);

}  // namespace basis
