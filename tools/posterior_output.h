#pragma once
// What `rocklab fit --posterior` writes beside its JSON: the draws (CSV or
// HDF5 by the file's extension) and the corner plot (SVG, written here
// without a plotting dependency). Formats in docs/identification.md.

#include <string>
#include <utility>
#include <vector>

#include "model/posterior.h"

namespace rocklab::tools {

/// The draws: one column per parameter (alpha, p, mu[, l], sigma, t_offset)
/// and log_posterior, one row per kept draw. `.h5`/`.hdf5`: an HDF5 table
/// `posterior` (export's H5Writer, units as attributes); else CSV with the
/// header `alpha,p,mu[,l],sigma,t_offset,log_posterior`. Written whole or
/// not at all.
/// @throws std::runtime_error naming the file.
/// `provenance` (common::ProvenanceFields): HDF5 root attributes, or the
/// CSV's sidecar STEM.provenance.csv (the CSV itself as above). `-`: the
/// CSV on standard output, no sidecar.
void WritePosteriorSamples(const std::string& path, const model::PosteriorResult& r,
                           const std::vector<std::pair<std::string, std::string>>& provenance = {});

/// The corner plot: marginal histograms on the diagonal, pairwise 2-D
/// histograms (shaded by density) below, the medians marked, as SVG.
/// @throws std::runtime_error naming the file.
/// `provenance`: in the SVG's <metadata> (common::AddProvenanceToFigure).
void WriteCornerSvg(const std::string& path, const model::PosteriorResult& r, const std::string& title,
                    const std::vector<std::pair<std::string, std::string>>& provenance = {});

}  // namespace rocklab::tools
