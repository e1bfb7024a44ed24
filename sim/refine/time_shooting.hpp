// The output-error fit in which the model finds its own events: hybrid multiple shooting with nodes
// placed by time (sim/refine/refine.hpp's last route; docs/method.md "The output-error refinement").
// Internal to sim/refine.
//
// Each chain is cut at nodes every L samples (TimeShootingNodeSpacing), each node with a free state
// s_i (n entries) and a mode q_i. Segment i is simulated from (s_i, q_i) with the model's own guard
// crossings and resets, and gives the residuals w_r·(x_r(t_k) − y_rk) of every measured row r at each
// of its samples (a missing sample has none) and, when the chain goes on, the continuity residuals
// (x(τ_{i+1}⁻) − s_{i+1})/(ε·c_j) (c_j the state's scale: σ_j for a measured state, for a hidden one
// σ scaled by its range over the node starts against the measured one's, or, when its node starts do
// not vary, from its sensitivities: the mismatch that moves the measured rows by about one σ per
// sample). The unknowns are θ (the unknown α, β, guard parameters) and every s_i; Ceres'
// Levenberg–Marquardt with a sparse Cholesky factorisation (the normal matrix is block-banded). No
// detected label enters: the detector gives only θ's start.
//
// Start: node states from the data (measured rows), hidden rows from the segment before simulated
// at the start or their reconstruction, whichever fits the node's segment better (a chain's first
// node: its reconstruction where finite, else the default state); modes, for an
// automaton, the one whose segment fits the node's samples best. Continuation: ε = 1, 0.1, 0.01, 0.001
// (kFirstWidth, kWidthStep, kLastWidth), a step shortened where it leaves the basin of a stage that
// fit the data to the noise: nearly free segments first, so that θ is fit to each segment's own data
// before a far start can lead the whole record astray; at each width the nodes' modes are settled
// from the segment before (at most kModeRounds solves), and samples more than kTrim robust standard
// deviations off on the model's own run are left out (a sample on the wrong side of a jump in a
// measured state has a residual the jump's size, which no sensitivity can explain). Final solve: every
// sample but those beside a jump of the model that are that far off, read on the model's own jump
// counts at the point reached (matched: each flow continued past the model's jump, so the cost is
// smooth there), again while those counts move, with the continuity nearly exact (kFinalWidth).
// Then, while the single-shooting Gauss–Newton step is longer than kOptimumStep standard errors, θ and
// every node take it and the final solve runs again (at most kOptimumSteps times); a fit still that
// far from its optimum is not converged.
//
// At the fit: the covariance of θ and each chain's first node state from the Gauss–Newton information
// of the data rows at the fitted σ with the continuity exact (every later node the run from the one
// before, linearised at the fit: the single-shooting information; the continuity rows, soft at any
// width, would let each node move by about ε·c_j as if the state were kicked there),
// the residual tests of sim/refine/residual_tests.hpp (with σ estimated, SigmaOverMad at most
// RefineOptions::rms_high, as on the labelled routes), and when they refuse whiteness (model error),
// the sandwich covariance with a Newey–West (Bartlett) estimate of the scores' autocovariance within
// chains (the estimate is then reported, `reported`, with a status that says the residuals are
// refused).
#pragma once

#include <optional>
#include <vector>

#include "sim/refine/fit.hpp"

namespace hysid {

// The continuity widths ε of the continuation, from kFirstWidth by steps of kWidthStep to kLastWidth,
// the fit's: a defect of ε · c_j costs as much as one sample's residual of one σ. After a stage at
// the noise's level whose next width costs more than kWidthCostGrowth times as much, that width's
// solve is dropped and the fit goes on from the stage's point a step's square root away, down to
// steps of kShortestWidthStep (each later step as short). At each width the nodes' modes are
// settled in at most kModeRounds solves.
constexpr double kFirstWidth = 1.0;
constexpr double kLastWidth = 1e-3;
constexpr double kWidthStep = 10.0;
constexpr double kWidthCostGrowth = 5.0;
constexpr double kShortestWidthStep = 1.5;
// A width within this factor of kLastWidth is kLastWidth (the steps' rounding).
constexpr double kWidthRounding = 1.0 + 1e-9;
// The final solve's width: the continuity nearly exact, so that the estimate is the output-error
// one of a single shooting (a node that may move by ε·c_j lets a parameter told over many segments
// wander off it, and the estimate spreads wider than the bound; bench/hopper-drag).
constexpr double kFinalWidth = 1e-4;
constexpr int kModeRounds = 4;
// After the final solve, the single-shooting Gauss–Newton step: when it is longer than kOptimumStep
// standard errors, taken (θ and every node) and the final solve run again, at most kOptimumSteps times;
// a fit whose step is still that long is not converged.
constexpr double kOptimumStep = 2.0;
constexpr int kOptimumSteps = 3;
// The first stage follows the data segment by segment when the median segment's mean squared
// weighted residual is at most this (twice the noise's variance; RefineResult::segments_fit_noise).
constexpr double kSegmentNoiseRatio = 2.0;
// Samples beyond this many robust standard deviations are left out of the continuation's solves.
constexpr double kTrim = 6.0;
// A hidden state whose node starts vary by less than this takes its continuity scale from its
// sensitivities instead of its range (WeighHidden).
constexpr double kFlatRange = 1e-12;
// The route's iteration budget: this many times RefineOptions::max_iterations over all its solves.
constexpr int kIterationBudget = 12;
// Each solve ends once a step changes the cost (½ Σ r² in units of σ) by less than this at the
// noise's level, ½·m·N for m measured rows and N samples (Ceres' relative function tolerance
// kCostResolution / ½mN; proportionally more where the cost is higher): a parameter s standard
// errors from the optimum costs s²/2 more, so 10⁻³ is the cost of a move of 0.045 SE, and the
// integration's own error in the cost is estimated at that order, which Levenberg–Marquardt
// otherwise chases with rejected steps, each a run of every segment. Against solves to a relative
// change of 10⁻⁹, the estimates of the drag-ball study (100 fits) moved by a median 0.003–0.014 SE,
// at most 0.074.
constexpr double kCostResolution = 1e-3;
// Near the noise's level (a cost of at most kStallCostRatio times the expected ½mN), a solve ends
// after kStalledSteps rejected steps in a row, at its best point: there what rejects the steps is
// the cost's roughness at the integration's and the events' scale (continuity residuals that a
// node's move cannot reduce below the integration error, a sample crossing an event), not a step
// too long, and Levenberg–Marquardt would try the same step again with a radius still too wide to
// shorten it. Over 24 user-system draws, every step taken after three or more rejections at such a
// cost gained at most 0.34 (in units of σ²; the same steps far from the noise gained up to 10⁹).
constexpr int kStalledSteps = 3;
constexpr double kStallCostRatio = 20.0;
// A guard no run of a start reaches: its γ entry moves to where the guard is reached on this share
// of the run's samples in the guard's mode (GammaReachingGuards).
constexpr double kGuardReach = 0.1;
// While no fit can be reported: this many starts of a Halton design over the box within this factor
// of the model's values either way (DesignStarts), the factor a user's start values may be off by.
constexpr int kDesignStarts = 16;
constexpr double kDesignFactor = 2.5;
// The searching starts (guards reached, the design) fit side by side, up to this many at a time.
constexpr int kSearchBatch = 4;

// Samples per segment for chains of `samples` samples in all (at least 4n + 4, about 1/48 of the data,
// at most 2 000).
long TimeShootingNodeSpacing(long samples, int n);

// The fit of the chains from `start` (full α, β, γ; its x0 unused). Status, estimates, covariance,
// residual statistics and `route` in the result; `chain_x0` the chains' first node states. With
// tie_flat_hidden, a hidden state whose node starts all take one value is held continuous
// (kFinalWidth) from the first width on, and `mended` names it.
RefineResult FitByTimeShooting(const Model& model, const std::vector<RefineChain>& chains,
                               const HybridParameters& start, const RefineOptions& options,
                               bool tie_flat_hidden = false);

// γ for a start whose guards the model never reaches (an automaton with unknown guard parameters):
// the nodes are started as FitByTimeShooting starts them from `start` and each segment is run; a jump
// map by which no run switches, whose guard reads one unknown γ entry, moves that entry to a quantile
// over the runs' samples in the map's mode of the value that puts the sample on the guard, the
// quantile kGuardReach from the side of its start (the least move that has the guard reached on that
// share of the samples; within its bounds). nullopt when nothing moves.
std::optional<Vec> GammaReachingGuards(const Model& model, const std::vector<RefineChain>& chains,
                                       const HybridParameters& start, const RefineOptions& options);

}  // namespace hysid
