#pragma once
// The character functions (skinning, normals, Delta Mush, features) run
// OpenMP over vertices. Inside a oneTBB task (the dataset pipeline) that would
// oversubscribe the cores, so a task opens a SerialRegion: while one is open
// on a thread, those functions run serially on it.
namespace gatcore::character {

class SerialRegion {
 public:
  SerialRegion() { ++depth(); }
  ~SerialRegion() { --depth(); }
  SerialRegion(const SerialRegion&) = delete;
  SerialRegion& operator=(const SerialRegion&) = delete;
  static bool active() { return depth() > 0; }

 private:
  static int& depth() {
    thread_local int d = 0;
    return d;
  }
};

}  // namespace gatcore::character
