// Slabs along z over MPI ranks (see decomposition.hpp).
#include "cfd/navier_stokes/decomposition.hpp"
#include <limits>
#include "cfd/navier_stokes/mpi_start.hpp"
#include <algorithm>
#include <cstdlib>
#include <stdexcept>
#include <string>
#ifdef FLAPSTAB_HAVE_MPI
#include <mpi.h>
#endif

namespace flapstab::ns {

#ifdef FLAPSTAB_HAVE_MPI
struct Decomposition::Comm {
  MPI_Comm comm = MPI_COMM_WORLD;
  bool owned = false;  // made by split(): freed with the decomposition (unless MPI has ended)
  Comm() = default;
  Comm(const Comm&) = delete;
  Comm& operator=(const Comm&) = delete;
  ~Comm() {
    int finalised = 0;
    MPI_Finalized(&finalised);
    if (owned && !finalised) MPI_Comm_free(&comm);
  }
};
#else
struct Decomposition::Comm {};
#endif

const void* Decomposition::communicator() const {
#ifdef FLAPSTAB_HAVE_MPI
  return comm_ ? &comm_->comm : nullptr;
#else
  return nullptr;
#endif
}

std::shared_ptr<const Decomposition> Decomposition::split(int per_group) const {
  if (per_group < 1 || size_ % per_group != 0)
    throw std::invalid_argument("navier_stokes decomposition: " + std::to_string(size_) +
                                " ranks do not make groups of " + std::to_string(per_group));
  auto d = std::make_shared<Decomposition>();
  d->group_ = rank_ / per_group;
  d->groups_ = size_ / per_group;
#ifdef FLAPSTAB_HAVE_MPI
  if (comm_) {
    d->comm_ = std::make_unique<Comm>();
    MPI_Comm_split(comm_->comm, d->group_, rank_, &d->comm_->comm);
    d->comm_->owned = true;
    MPI_Comm_rank(d->comm_->comm, &d->rank_);
    MPI_Comm_size(d->comm_->comm, &d->size_);
  }
#endif
  return d;
}

Decomposition::Decomposition() = default;
Decomposition::~Decomposition() = default;

bool Decomposition::mpi_available() {
#ifdef FLAPSTAB_HAVE_MPI
  return true;
#else
  return false;
#endif
}

std::shared_ptr<const Decomposition> Decomposition::world() {
#ifdef FLAPSTAB_HAVE_MPI
  int init = 0;
  MPI_Initialized(&init);
  if (!init) throw std::logic_error("navier_stokes decomposition: MPI is not initialised (call MPI_Init first)");
  auto d = std::make_shared<Decomposition>();
  d->comm_ = std::make_unique<Comm>();
  MPI_Comm_rank(MPI_COMM_WORLD, &d->rank_);
  MPI_Comm_size(MPI_COMM_WORLD, &d->size_);
  return d;
#else
  throw std::runtime_error("navier_stokes decomposition: this flapstab was built without MPI (install libopenmpi-dev "
                           "and openmpi-bin, then configure again)");
#endif
}

int Decomposition::launched_processes() {
  for (const char* var : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE"})
    if (const char* v = std::getenv(var)) {
      const int n = std::atoi(v);
      if (n > 1) return n;
    }
  return 1;
}

std::shared_ptr<const Decomposition> Decomposition::launched() {
  if (launched_processes() <= 1) return std::make_shared<const Decomposition>();
#ifdef FLAPSTAB_HAVE_MPI
  start_mpi();
#endif
  return world();  // (throws when built without MPI)
}

void Decomposition::abort(int status) const {
#ifdef FLAPSTAB_HAVE_MPI
  int init = 0, finalised = 0;
  MPI_Initialized(&init);
  MPI_Finalized(&finalised);
  if (init && !finalised) MPI_Abort(MPI_COMM_WORLD, status);  // the whole job, whichever group this rank is in
#endif
  std::exit(status);
}

std::vector<Slab> Decomposition::slabs_of(int cells, int unit, int ranks, bool periodic) {
  if (unit < 1 || cells % unit != 0)
    throw std::invalid_argument("navier_stokes decomposition: " + std::to_string(cells) +
                                " planes are not whole units of " + std::to_string(unit));
  const int units = cells / unit;
  if (units < ranks)
    throw std::invalid_argument("navier_stokes decomposition: the z axis has " + std::to_string(cells) + " cells, " +
                                std::to_string(units) + " blocks of " + std::to_string(unit) +
                                " planes (the multigrid's alignment), fewer than the " + std::to_string(ranks) +
                                " ranks: use fewer ranks or more z cells");
  std::vector<Slab> out(static_cast<std::size_t>(ranks));
  int at = 0;
  for (int r = 0; r < ranks; ++r) {
    const int u = units / ranks + (r < units % ranks ? 1 : 0);
    Slab& s = out[std::size_t(r)];
    s.offset = at;
    s.n = u * unit;
    at += s.n;
    s.cut_lo = ranks > 1 && (periodic || r > 0);
    s.cut_hi = ranks > 1 && (periodic || r + 1 < ranks);
  }
  return out;
}

#ifdef FLAPSTAB_HAVE_MPI
namespace {
template <class T>
MPI_Datatype type();
template <>
MPI_Datatype type<double>() { return MPI_DOUBLE; }
template <>
MPI_Datatype type<float>() { return MPI_FLOAT; }

// Adds the wall time of a communication (its transfer, and the wait for a neighbour that is not there yet) to
// Traffic::seconds.
struct Timed {
  double& total;
  double start = MPI_Wtime();
  explicit Timed(double& t) : total(t) {}
  ~Timed() { total += MPI_Wtime() - start; }
};

template <class T>
void exchange_planes(MPI_Comm comm, int rank, int size, T* x, const Shape& s, const Slab& sl,
                     Decomposition::Traffic& traffic) {
  if (size < 2 || !(sl.cut_lo || sl.cut_hi)) return;
  const Timed timed(traffic.seconds);
  ++traffic.exchanges;
  traffic.bytes += double(s.sz) * sizeof(T) * ((sl.cut_lo ? 1 : 0) + (sl.cut_hi ? 1 : 0));
  const int lower = sl.cut_lo ? (rank + size - 1) % size : MPI_PROC_NULL;
  const int upper = sl.cut_hi ? (rank + 1) % size : MPI_PROC_NULL;
  const int count = int(s.sz);
  // Upwards: my plane nz to the upper neighbour's plane 0; downwards: my plane 1 to the lower one's plane nz + 1.
  MPI_Sendrecv(x + s(0, 0, s.nz), count, type<T>(), upper, 11, x, count, type<T>(), lower, 11, comm, MPI_STATUS_IGNORE);
  MPI_Sendrecv(x + s(0, 0, 1), count, type<T>(), lower, 12, x + s(0, 0, s.nz + 1), count, type<T>(), upper, 12, comm,
               MPI_STATUS_IGNORE);
}
}  // namespace

void Decomposition::exchange(double* x, const Shape& s, const Slab& sl) const {
  if (comm_) exchange_planes(comm_->comm, rank_, size_, x, s, sl, traffic_);
}
void Decomposition::exchange(float* x, const Shape& s, const Slab& sl) const {
  if (comm_) exchange_planes(comm_->comm, rank_, size_, x, s, sl, traffic_);
}

void Decomposition::gather_planes(float* x, const Shape& whole, const std::vector<Slab>& slabs) const {
  if (!comm_ || size_ < 2) return;
  std::vector<int> counts(static_cast<std::size_t>(size_)), displs(static_cast<std::size_t>(size_));
  for (int r = 0; r < size_; ++r) {
    counts[std::size_t(r)] = int(whole.sz) * slabs[std::size_t(r)].n;
    displs[std::size_t(r)] = int(whole(0, 0, slabs[std::size_t(r)].offset + 1));
  }
  const Timed timed(traffic_.seconds);
  ++traffic_.gathers;
  traffic_.bytes += double(counts[std::size_t(rank_)]) * sizeof(float) * (size_ - 1);
  MPI_Allgatherv(MPI_IN_PLACE, 0, MPI_DATATYPE_NULL, x, counts.data(), displs.data(), MPI_FLOAT, comm_->comm);
}

void Decomposition::gather_field(const Field& local, const std::vector<Slab>& slabs, Field& whole) const {
  const Shape& s = local.shape();
  if (!comm_ || size_ < 2) {
    if (rank_ == 0) whole = local;
    return;
  }
  const int plane = int(s.sz);
  std::vector<int> counts(static_cast<std::size_t>(size_)), displs(static_cast<std::size_t>(size_));
  for (int r = 0; r < size_; ++r) {  // planes 1 .. n, with plane 0 on the first rank and n + 1 on the last
    const Slab& sl = slabs[std::size_t(r)];
    const int first = r == 0 ? 0 : 1, last = r + 1 == size_ ? sl.n + 1 : sl.n;
    counts[std::size_t(r)] = plane * (last - first + 1);
    displs[std::size_t(r)] = plane * (sl.offset + first);
  }
  const int first = rank_ == 0 ? 0 : 1;
  const Timed timed(traffic_.seconds);
  ++traffic_.gathers;
  traffic_.bytes += double(counts[std::size_t(rank_)]) * sizeof(double);
  MPI_Gatherv(local.data() + s(0, 0, first), counts[std::size_t(rank_)], MPI_DOUBLE,
              rank_ == 0 ? whole.data() : nullptr, counts.data(), displs.data(), MPI_DOUBLE, 0, comm_->comm);
}

void Decomposition::widen(const Field& local, const Slab& sl, int depth, Field& window) const {
  const Shape& s = local.shape();
  const int lo = sl.cut_lo ? depth : 0;
  std::copy_n(local.data(), s.size(), window.data() + window.shape()(0, 0, lo));
  if (!comm_ || size_ < 2 || !(sl.cut_lo || sl.cut_hi)) return;
  const int lower = sl.cut_lo ? (rank_ + size_ - 1) % size_ : MPI_PROC_NULL;
  const int upper = sl.cut_hi ? (rank_ + 1) % size_ : MPI_PROC_NULL;
  const int count = int(s.sz) * (depth + 1);
  double* w = window.data();
  const Shape& ws = window.shape();
  // Upwards: my planes n - depth .. n to the upper neighbour's window planes 0 .. depth; downwards: my planes
  // 1 .. depth + 1 to the lower one's planes above its own.
  const Timed timed(traffic_.seconds);
  ++traffic_.exchanges;
  traffic_.bytes += double(count) * sizeof(double) * ((sl.cut_lo ? 1 : 0) + (sl.cut_hi ? 1 : 0));
  MPI_Sendrecv(local.data() + s(0, 0, s.nz - depth), sl.cut_hi ? count : 0, MPI_DOUBLE, upper, 21, w,
               sl.cut_lo ? count : 0, MPI_DOUBLE, lower, 21, comm_->comm, MPI_STATUS_IGNORE);
  MPI_Sendrecv(local.data() + s(0, 0, 1), sl.cut_lo ? count : 0, MPI_DOUBLE, lower, 22,
               w + ws(0, 0, lo + s.nz + 1), sl.cut_hi ? count : 0, MPI_DOUBLE, upper, 22, comm_->comm,
               MPI_STATUS_IGNORE);
}

double Decomposition::sum(double v) const {
  if (comm_ && size_ > 1) {
    const Timed timed(traffic_.seconds);
    ++traffic_.reductions;
    MPI_Allreduce(MPI_IN_PLACE, &v, 1, MPI_DOUBLE, MPI_SUM, comm_->comm);
  }
  return v;
}
void Decomposition::sum(double* v, int n) const {
  if (comm_ && size_ > 1) {
    const Timed timed(traffic_.seconds);
    ++traffic_.reductions;
    MPI_Allreduce(MPI_IN_PLACE, v, n, MPI_DOUBLE, MPI_SUM, comm_->comm);
  }
}
void Decomposition::broadcast(std::string& text) const {
  if (!comm_ || size_ <= 1) return;
  // The length first, without a busy wait: the other ranks may wait here for minutes while rank 0 waits for a file
  // lock (another group's run), and Open MPI's blocking collectives would spin on their cores.
  long length = rank_ == 0 ? long(text.size()) : 0;
  MPI_Request request;
  MPI_Ibcast(&length, 1, MPI_LONG, 0, comm_->comm, &request);
  wait_without_spinning(&request);
  if (rank_ != 0) text.assign(std::size_t(length), '\0');
  if (length > 0) MPI_Bcast(text.data(), int(length), MPI_CHAR, 0, comm_->comm);
}

namespace {
int message_count(std::size_t count) {
  if (count > std::size_t(std::numeric_limits<int>::max()))
    throw std::length_error("a slab of more than 2^31 values in one message");
  return int(count);
}
}  // namespace

void Decomposition::send_to(int to, const double* v, std::size_t count, int tag) const {
  const Timed timed(traffic_.seconds);
  ++traffic_.gathers;
  traffic_.bytes += double(count) * sizeof(double);
  MPI_Send(v, message_count(count), MPI_DOUBLE, to, tag, comm_->comm);
}

void Decomposition::receive_from(int from, double* v, std::size_t count, int tag) const {
  const Timed timed(traffic_.seconds);
  MPI_Recv(v, message_count(count), MPI_DOUBLE, from, tag, comm_->comm, MPI_STATUS_IGNORE);
}

void Decomposition::broadcast(double* v, int n) const {
  if (!comm_ || size_ <= 1) return;
  const Timed timed(traffic_.seconds);
  MPI_Bcast(v, n, MPI_DOUBLE, 0, comm_->comm);
}

double Decomposition::max(double v) const {
  if (comm_ && size_ > 1) {
    const Timed timed(traffic_.seconds);
    ++traffic_.reductions;
    MPI_Allreduce(MPI_IN_PLACE, &v, 1, MPI_DOUBLE, MPI_MAX, comm_->comm);
  }
  return v;
}
#else
void Decomposition::gather_field(const Field& local, const std::vector<Slab>&, Field& whole) const { whole = local; }
void Decomposition::widen(const Field& local, const Slab&, int, Field& window) const { window = local; }
void Decomposition::exchange(double*, const Shape&, const Slab&) const {}
void Decomposition::exchange(float*, const Shape&, const Slab&) const {}
void Decomposition::gather_planes(float*, const Shape&, const std::vector<Slab>&) const {}
double Decomposition::sum(double v) const { return v; }
void Decomposition::sum(double*, int) const {}
double Decomposition::max(double v) const { return v; }
void Decomposition::broadcast(std::string&) const {}
void Decomposition::broadcast(double*, int) const {}
void Decomposition::send_to(int, const double*, std::size_t, int) const {
  throw std::logic_error("Decomposition::send_to without MPI");
}
void Decomposition::receive_from(int, double*, std::size_t, int) const {
  throw std::logic_error("Decomposition::receive_from without MPI");
}
#endif

}  // namespace flapstab::ns
