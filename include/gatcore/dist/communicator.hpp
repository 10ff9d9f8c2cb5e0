#pragma once
// Processes that train one model together (data parallelism over MPI).
//
// A Communicator is the group: its size, this process's rank, and the few
// collectives training needs. Sums are *ordered*: element i of the result is
// ((x_0 + x_1) + x_2) + ... over the ranks in rank order, computed the same
// way on every rank, so the result is the same bits everywhere and from run
// to run, whatever MPI's own reduction algorithms would choose (MPI_Allreduce
// leaves its order to the implementation). See mpi_communicator.cpp for how.
//
// world() is the group this process was launched in: the MPI world when the
// library was built with MPI and the process was started by an MPI launcher
// (mpirun, srun, ...: MPI is initialised on first use), else a group of one
// (no MPI calls at all; the single-process path is unchanged).
#include <cstddef>
#include <memory>
#include <string>

namespace gatcore::dist {

class Communicator {
 public:
  virtual ~Communicator() = default;
  virtual int rank() const = 0;
  virtual int size() const = 0;
  // In-place element-wise ordered sums (see above).
  virtual void sum(float* data, std::size_t n) = 0;
  virtual void sum(double* data, std::size_t n) = 0;
  // rank `root`'s bytes to every rank (n bytes, the same n everywhere).
  virtual void broadcast(void* data, std::size_t n, int root) = 0;
  virtual void barrier() = 0;
  // Ends every process of the group now with `code`, after printing
  // `message` on this one: the way out when one rank fails, so the others
  // never wait for it in a collective. A group of one just exits.
  [[noreturn]] virtual void abort(const std::string& message, int code) = 0;
  // Bytes this process has sent in collectives so far, and the seconds it
  // has spent in them (waiting included): the communication side of a step
  // (bench/RESULTS.md).
  virtual std::size_t bytes_sent() const = 0;
  virtual double seconds_in_collectives() const = 0;
};

// The single-process group: size 1, sums are identities.
std::unique_ptr<Communicator> make_single_process();

// The process's group (see above).
Communicator& world();

// Whether this build has MPI (CMake found it).
bool mpi_built();
// Whether this process looks started by an MPI launcher (its environment).
bool launched_by_mpi();

}  // namespace gatcore::dist
