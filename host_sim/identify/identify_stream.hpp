// identify for logs too large to load: the conventions and the core's
// configuration come from the head of the log, then the whole log streams
// through the core chunk by chunk, in memory bounded by a chunk. Host only.
#pragma once
#include <string>

#include "io/csv_trace.hpp"
#include "identify.hpp"

namespace feedid::host {

struct StreamOptions {
  double head_s = kConventionsHead_s;  ///< the head that sets conventions, velocity filter and band edges (s)
  double chunk_s = 30.0;   ///< samples filtered and pushed per chunk (s)
  double margin_s = 1.0;   ///< overlap at chunk edges, so the zero-phase filter never sees an edge it invents (s)
};

/// The same result layout as identify(), from a CsvStream. The force lag
/// and the velocity filter (or the column) chosen on the head are stated
/// for every chunk. Standard errors: a delete-one-group jackknife over ten
/// groups of 10 s blocks dealt round-robin (the core's own below 50 s of
/// data), and the timing term measured on the head; the JSON says so
/// (input.streamed).
IdentifyResult identify_stream(CsvStream& in, const std::string& source, const IdentifyOptions& opt,
                               const StreamOptions& so = {});

}  // namespace feedid::host
