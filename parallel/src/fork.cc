#include "vinci/parallel/fork.h"

#include <fcntl.h>
#include <poll.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <exception>
#include <stdexcept>
#include <string>

namespace vinci::parallel {
namespace {

// A child's message: one status byte, then the result or the error's text.
constexpr char kOk = 0, kInvalidArgument = 1, kError = 2;

// Writes all of `data` to fd (the child's side; retries on EINTR and short writes).
bool WriteAll(int fd, const char* data, std::size_t size) {
  while (size > 0) {
    const ssize_t w = ::write(fd, data, size);
    if (w < 0 && errno == EINTR) continue;
    if (w <= 0) return false;
    data += w;
    size -= static_cast<std::size_t>(w);
  }
  return true;
}

// In the child: runs the chunk, sends its message, and leaves without running the parent's
// exit handlers or flushing its inherited stdio buffers (_exit).
[[noreturn]] void RunChild(int fd, const ChunkFn& fn, const Buffer& job, int begin, int end) {
  Buffer msg;
  try {
    msg = fn(job, begin, end);
    msg.insert(msg.begin(), kOk);
  } catch (const std::invalid_argument& e) {
    msg = std::string(1, kInvalidArgument) + e.what();
  } catch (const std::exception& e) {
    msg = std::string(1, kError) + e.what();
  } catch (...) {
    msg = std::string(1, kError) + "unknown exception";
  }
  const bool sent = WriteAll(fd, msg.data(), msg.size());
  ::close(fd);
  ::_exit(sent ? 0 : 1);
}

std::string HowItEnded(int status) {
  if (WIFSIGNALED(status))
    return "was killed by signal " + std::to_string(WTERMSIG(status)) + " (" +
           strsignal(WTERMSIG(status)) + ")";
  if (WIFEXITED(status)) return "exited with status " + std::to_string(WEXITSTATUS(status));
  return "ended";
}

struct Child {
  pid_t pid = -1;
  int fd = -1;
  int chunk = -1;
  int slot = -1;
  Buffer data;
};

}  // namespace

ForkDistributor::ForkDistributor(int processes) : processes_(processes) {
  if (processes < 1)
    throw std::invalid_argument("parallel::ForkDistributor: processes must be >= 1, got " +
                                std::to_string(processes));
  items_.assign(static_cast<std::size_t>(processes), 0);
}

Buffer ForkDistributor::Map(const Buffer& job, int n, const ChunkFn& fn,
                            const MapOptions& options) {
  if (processes_ == 1) {  // here, in order
    LocalDistributor local;
    const Buffer out = local.Map(job, n, fn, options);
    items_[0] += local.ItemsPerRank()[0];
    return out;
  }
  const std::vector<int> bounds = ChunkBounds(n, processes_, options);
  const int chunks = bounds.empty() ? 0 : static_cast<int>(bounds.size()) - 1;
  std::vector<Buffer> results(static_cast<std::size_t>(chunks));
  int failed_chunk = -1;  // the lowest-index failing chunk
  std::exception_ptr failed_error, callback_error;
  int next = 0, done = 0;
  const auto fail = [&](int k, std::exception_ptr e) {
    if (failed_chunk < 0 || k < failed_chunk) {
      failed_chunk = k;
      failed_error = std::move(e);
    }
  };
  const auto finished = [&](int k, int slot, bool ok) {
    const int b = bounds[static_cast<std::size_t>(k)], e = bounds[static_cast<std::size_t>(k) + 1];
    items_[static_cast<std::size_t>(slot)] += e - b;
    done += e - b;
    if (callback_error) return;
    try {
      if (ok && options.on_chunk) options.on_chunk(b, e, results[static_cast<std::size_t>(k)]);
      if (options.progress) options.progress(done, n);
    } catch (...) {
      callback_error = std::current_exception();
    }
  };
  const auto stopping = [&] { return failed_chunk >= 0 || callback_error; };

  std::vector<Child> running;
  std::vector<bool> busy(static_cast<std::size_t>(processes_), false);
  const auto spawn = [&](int k) {
    int slot = 0;
    while (busy[static_cast<std::size_t>(slot)]) ++slot;
    int fds[2];
    if (::pipe2(fds, O_CLOEXEC) != 0)
      throw std::runtime_error(std::string("parallel::ForkDistributor: pipe: ") +
                               std::strerror(errno));
    std::fflush(nullptr);  // nothing buffered is written twice
    const pid_t pid = ::fork();
    if (pid < 0) {
      const int err = errno;
      ::close(fds[0]);
      ::close(fds[1]);
      throw std::runtime_error(std::string("parallel::ForkDistributor: fork: ") +
                               std::strerror(err));
    }
    if (pid == 0) {
      ::close(fds[0]);
      RunChild(fds[1], fn, job, bounds[static_cast<std::size_t>(k)],
               bounds[static_cast<std::size_t>(k) + 1]);
    }
    ::close(fds[1]);
    busy[static_cast<std::size_t>(slot)] = true;
    running.push_back(Child{pid, fds[0], k, slot, {}});
  };
  // Reaps a child whose pipe reached its end and records its chunk.
  const auto collect = [&](Child& c) {
    ::close(c.fd);
    int status = 0;
    while (::waitpid(c.pid, &status, 0) < 0 && errno == EINTR) {
    }
    busy[static_cast<std::size_t>(c.slot)] = false;
    const int b = bounds[static_cast<std::size_t>(c.chunk)];
    const int e = bounds[static_cast<std::size_t>(c.chunk) + 1];
    bool ok = false;
    if (c.data.empty()) {
      fail(c.chunk,
           std::make_exception_ptr(std::runtime_error(
               "parallel::ForkDistributor: the process running items [" + std::to_string(b) + ", " +
               std::to_string(e) + ") " + HowItEnded(status) + " without a result")));
    } else if (c.data[0] == kOk) {
      results[static_cast<std::size_t>(c.chunk)] = c.data.substr(1);
      ok = true;
    } else if (c.data[0] == kInvalidArgument) {
      fail(c.chunk, std::make_exception_ptr(std::invalid_argument(c.data.substr(1))));
    } else {
      fail(c.chunk, std::make_exception_ptr(std::runtime_error(c.data.substr(1))));
    }
    finished(c.chunk, c.slot, ok);
  };
  std::exception_ptr spawn_error;
  for (;;) {
    while (!spawn_error && !stopping() && next < chunks &&
           static_cast<int>(running.size()) < processes_) {
      try {
        spawn(next);
        ++next;
      } catch (...) {
        spawn_error = std::current_exception();
      }
    }
    if (running.empty()) break;
    std::vector<pollfd> fds(running.size());
    for (std::size_t i = 0; i < running.size(); ++i) fds[i] = pollfd{running[i].fd, POLLIN, 0};
    if (::poll(fds.data(), fds.size(), -1) < 0) {
      if (errno == EINTR) continue;
      throw std::runtime_error(std::string("parallel::ForkDistributor: poll: ") +
                               std::strerror(errno));
    }
    for (std::size_t i = running.size(); i-- > 0;) {
      if (fds[i].revents == 0) continue;
      char buf[1 << 16];
      const ssize_t r = ::read(running[i].fd, buf, sizeof buf);
      if (r < 0 && errno == EINTR) continue;
      if (r > 0) {
        running[i].data.append(buf, static_cast<std::size_t>(r));
        continue;
      }
      if (r < 0) running[i].data.clear();  // a read error: the message is lost
      collect(running[i]);
      running.erase(running.begin() + static_cast<std::ptrdiff_t>(i));
    }
  }
  if (spawn_error && failed_chunk < 0 && !callback_error) std::rethrow_exception(spawn_error);
  if (callback_error) std::rethrow_exception(callback_error);
  if (failed_error) std::rethrow_exception(failed_error);
  Buffer out;
  for (const Buffer& b : results) out += b;
  return out;
}

}  // namespace vinci::parallel
