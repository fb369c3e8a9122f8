// Bounded reading of input files (input_file.h).
#include "vinci/sim/solvers/input_file.h"

#include <sys/stat.h>

#include <fstream>
#include <stdexcept>
#include <string>

namespace vinci::sim {

std::string ReadInputFile(const std::string& path, const std::string& what, std::size_t max_bytes) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) throw std::invalid_argument(path + ": cannot open " + what);
  if (S_ISDIR(st.st_mode))
    throw std::invalid_argument(path + ": cannot read " + what + ": it is a directory");
  if (S_ISCHR(st.st_mode) || S_ISBLK(st.st_mode))
    throw std::invalid_argument(path + ": cannot read " + what +
                                ": expected a regular file, got a device");
  const std::string too_big = path + ": cannot read " + what + ": larger than the limit of " +
                              std::to_string(max_bytes) + " bytes";
  if (S_ISREG(st.st_mode) && static_cast<unsigned long long>(st.st_size) > max_bytes)
    throw std::invalid_argument(too_big);
  std::ifstream in(path, std::ios::binary);
  if (!in.is_open()) throw std::invalid_argument(path + ": cannot open " + what);
  std::string text;
  char buf[1 << 16];
  while (in.read(buf, sizeof(buf)) || in.gcount() > 0) {
    text.append(buf, static_cast<std::size_t>(in.gcount()));
    if (text.size() > max_bytes) throw std::invalid_argument(too_big);
    if (!in) break;
  }
  if (in.bad() || !in.eof()) throw std::invalid_argument(path + ": cannot read " + what);
  return text;
}

}  // namespace vinci::sim
