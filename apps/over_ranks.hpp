// A subcommand run by every rank of an MPI job (mpiexec): how its errors end the ranks.
#pragma once
#include <functional>
#include <string>
#include "cfd/navier_stokes/decomposition.hpp"

namespace flapstab {

// Runs body on this rank of `ranks` (one flow's ranks: all of an mpiexec job, or one group of it). An error every
// rank of `ranks` meets alike (InputError, SolveError, OutputError, Interrupted, ns::RanksFailed: the same input, or
// rank 0's failure made every rank's) is rethrown on its rank 0, which prints it, and ends the others silently with
// the same exit status; any other exception may be this rank's alone while the others wait for it in a collective
// operation: it is printed with the rank (`command`, e.g. "flapstab cfd", names the program) and ends the whole job
// (MPI_Abort). On one rank without MPI, body().
int run_over_ranks(const ns::Decomposition& ranks, const std::string& command, const std::function<int()>& body);

}  // namespace flapstab
