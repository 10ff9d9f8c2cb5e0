// The MPI group (compiled only when CMake found MPI: GATCORE_HAS_MPI).
//
// Ordered sums without MPI_Allreduce: MPI leaves the order in which
// MPI_Allreduce adds the ranks' contributions to the implementation (it may
// change with the message size, the number of ranks or the tuning), so two
// runs, or two ranks, could round differently. Instead the buffer is cut into
// one chunk per rank; MPI_Alltoallv sends every rank's copy of chunk r to
// rank r, which adds the copies in rank order; MPI_Allgatherv hands the
// summed chunks to everyone. Both collectives only move data, so the result
// is fixed by this code. Each rank sends (N-1)/N of the buffer twice, the
// same volume as a ring allreduce (reduce-scatter + allgather).
#include <mpi.h>

#include <cstdio>
#include <cstdlib>
#include <limits>
#include <vector>

#include "gatcore/dist/communicator.hpp"
#include "gatcore/error.hpp"

namespace gatcore::dist {

namespace {

void check(int rc, const char* what) {
  if (rc == MPI_SUCCESS) return;
  char text[MPI_MAX_ERROR_STRING];
  int len = 0;
  MPI_Error_string(rc, text, &len);
  throw Error(std::string("MPI: ") + what + " failed: " + std::string(text, std::size_t(len)));
}

void finalize_at_exit() {
  int fin = 0;
  MPI_Finalized(&fin);
  if (!fin) MPI_Finalize();
}

template <class T>
MPI_Datatype mpi_type();
template <>
MPI_Datatype mpi_type<float>() { return MPI_FLOAT; }
template <>
MPI_Datatype mpi_type<double>() { return MPI_DOUBLE; }

class MpiWorld final : public Communicator {
 public:
  MpiWorld() {
    int init = 0;
    MPI_Initialized(&init);
    if (!init) {
      int provided = 0;
      // MPI is called from the main thread only (OpenMP and oneTBB work inside each rank).
      check(MPI_Init_thread(nullptr, nullptr, MPI_THREAD_FUNNELED, &provided), "MPI_Init_thread");
      std::atexit(finalize_at_exit);
    }
    // A failing rank aborts the job (the default, said explicitly): nobody waits forever.
    MPI_Comm_set_errhandler(MPI_COMM_WORLD, MPI_ERRORS_ARE_FATAL);
    MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
    MPI_Comm_size(MPI_COMM_WORLD, &size_);
  }
  int rank() const override { return rank_; }
  int size() const override { return size_; }
  void sum(float* data, std::size_t n) override { ordered_sum(data, n); }
  void sum(double* data, std::size_t n) override { ordered_sum(data, n); }
  void broadcast(void* data, std::size_t n, int root) override {
    GATCORE_CHECK(n <= std::size_t(std::numeric_limits<int>::max()), "broadcast: ", n, " bytes is too many");
    Timed t{seconds_};
    check(MPI_Bcast(data, int(n), MPI_BYTE, root, MPI_COMM_WORLD), "MPI_Bcast");
    if (rank_ == root) sent_ += n * std::size_t(size_ - 1);
  }
  void barrier() override {
    Timed t{seconds_};
    check(MPI_Barrier(MPI_COMM_WORLD), "MPI_Barrier");
  }
  [[noreturn]] void abort(const std::string& message, int code) override {
    std::fprintf(stderr, "%s\n", message.c_str());
    std::fflush(nullptr);
    MPI_Abort(MPI_COMM_WORLD, code);
    std::_Exit(code);  // MPI_Abort does not return; in case it does
  }
  std::size_t bytes_sent() const override { return sent_; }
  double seconds_in_collectives() const override { return seconds_; }

 private:
  template <class T>
  void ordered_sum(T* data, std::size_t n) {
    if (size_ == 1 || n == 0) return;
    Timed t{seconds_};
    const std::size_t N = std::size_t(size_), me = std::size_t(rank_);
    GATCORE_CHECK(n <= std::size_t(std::numeric_limits<int>::max()), "sum: ", n, " elements is too many for one call");
    const auto lo = [&](std::size_t r) { return n * r / N; };
    std::vector<int> counts(N), displs(N), rcounts(N), rdispls(N);
    const std::size_t m = lo(me + 1) - lo(me);  // my chunk
    for (std::size_t r = 0; r < N; ++r) {
      counts[r] = int(lo(r + 1) - lo(r));
      displs[r] = int(lo(r));
      rcounts[r] = int(m);
      rdispls[r] = int(r * m);
    }
    recv_.resize(N * m * sizeof(T));
    T* recv = reinterpret_cast<T*>(recv_.data());
    const MPI_Datatype dt = mpi_type<T>();
    check(MPI_Alltoallv(data, counts.data(), displs.data(), dt, recv, rcounts.data(), rdispls.data(), dt,
                        MPI_COMM_WORLD),
          "MPI_Alltoallv");
    T* mine = data + lo(me);
    for (std::size_t i = 0; i < m; ++i) mine[i] = recv[i];
    for (std::size_t r = 1; r < N; ++r) {
      const T* src = recv + r * m;
      for (std::size_t i = 0; i < m; ++i) mine[i] += src[i];
    }
    check(MPI_Allgatherv(MPI_IN_PLACE, 0, dt, data, counts.data(), displs.data(), dt, MPI_COMM_WORLD),
          "MPI_Allgatherv");
    sent_ += (n - m + m * (N - 1)) * sizeof(T);
  }

  // Adds the time from its construction to its end to seconds_.
  struct Timed {
    double& acc;
    double t0 = MPI_Wtime();
    ~Timed() { acc += MPI_Wtime() - t0; }
  };
  int rank_ = 0, size_ = 1;
  std::size_t sent_ = 0;
  double seconds_ = 0;
  std::vector<unsigned char> recv_;
};

}  // namespace

std::unique_ptr<Communicator> make_mpi_world() { return std::make_unique<MpiWorld>(); }

}  // namespace gatcore::dist
