// Errors of a subcommand run over MPI ranks (over_ranks.hpp).
#include "apps/over_ranks.hpp"
#include <cstdio>
#include <fmt/format.h>
#include "core/errors.hpp"

namespace flapstab {

int run_over_ranks(const ns::Decomposition& ranks, const std::string& command, const std::function<int()>& body) {
  if (!ranks.distributed()) return body();
  const bool speaks = ranks.rank() == 0;
  try {
    return body();
  } catch (const InputError&) {
    if (speaks) throw;
    return 2;
  } catch (const SolveError&) {
    if (speaks) throw;
    return 3;
  } catch (const OutputError&) {
    if (speaks) throw;
    return 4;
  } catch (const Interrupted& e) {
    if (speaks) throw;
    return 128 + e.signal();
  } catch (const ns::RanksFailed&) {
    if (speaks) throw;
    return 1;
  } catch (const std::exception& e) {  // perhaps this rank's alone, with the others waiting for it: end them all
    fmt::print(stderr, "{} (rank {} of {}): error: {}\n", command, ranks.rank(), ranks.size(), e.what());
    ranks.abort(1);
  }
}

}  // namespace flapstab
