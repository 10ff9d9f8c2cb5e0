// The single-process group and world(); the MPI group is in
// mpi_communicator.cpp, compiled only when CMake found MPI.
#include "gatcore/dist/communicator.hpp"

#include <cstdio>
#include <cstdlib>
#include <mutex>

namespace gatcore::dist {

namespace {

class SingleProcess final : public Communicator {
 public:
  int rank() const override { return 0; }
  int size() const override { return 1; }
  void sum(float*, std::size_t) override {}
  void sum(double*, std::size_t) override {}
  void broadcast(void*, std::size_t, int) override {}
  void barrier() override {}
  [[noreturn]] void abort(const std::string& message, int code) override {
    std::fprintf(stderr, "%s\n", message.c_str());
    std::fflush(nullptr);
    std::exit(code);
  }
  std::size_t bytes_sent() const override { return 0; }
  double seconds_in_collectives() const override { return 0; }
};

}  // namespace

std::unique_ptr<Communicator> make_single_process() { return std::make_unique<SingleProcess>(); }

bool launched_by_mpi() {
  // Open MPI's mpirun, MPICH / Intel MPI (PMI), PMIx launchers (Open MPI 5,
  // srun --mpi=pmix) and Slurm's PMI-2.
  for (const char* v : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_RANK", "PMI_RANK"})
    if (std::getenv(v)) return true;
  return false;
}

#ifdef GATCORE_HAS_MPI
std::unique_ptr<Communicator> make_mpi_world();  // mpi_communicator.cpp
bool mpi_built() { return true; }
#else
bool mpi_built() { return false; }
#endif

Communicator& world() {
  static std::unique_ptr<Communicator> w;
  static std::once_flag once;
  std::call_once(once, [] {
#ifdef GATCORE_HAS_MPI
    if (launched_by_mpi()) w = make_mpi_world();
#else
    // N copies that each think they are alone would each train the whole
    // model and overwrite each other's checkpoints: refuse.
    for (const char* v : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "SLURM_NTASKS"})
      if (const char* n = std::getenv(v); launched_by_mpi() && n && std::atoi(n) > 1) {
        std::fprintf(stderr, "gatcore: started by an MPI launcher with %s processes (%s), but built without MPI "
                             "(install libopenmpi-dev and reconfigure)\n", n, v);
        std::exit(2);
      }
#endif
    if (!w) w = make_single_process();
  });
  return *w;
}

}  // namespace gatcore::dist
