#pragma once
// Runs a project binary as a real child process (end-to-end tests, benchmarks): start with
// arguments, capture its output to a file, wait with a timeout, signal it. The destructor kills a
// child that is still running, so a failing test never leaves processes behind.

#include <fcntl.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

namespace epmap::process {

class ChildProcess {
 public:
  // Starts `binary` (a path) with `args`; stdout and stderr go to `log_path`.
  ChildProcess(const std::filesystem::path& binary, const std::vector<std::string>& args,
               const std::filesystem::path& log_path)
      : log_path_(log_path) {
    pid_ = ::fork();
    if (pid_ == 0) {
      const int fd = ::open(log_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      if (fd >= 0) {
        ::dup2(fd, 1);
        ::dup2(fd, 2);
        ::close(fd);
      }
      ::setenv("SKIP_DEFAULT_XML_FILE", "1", 1);
      std::vector<char*> argv;
      std::string bin = binary.string();
      argv.push_back(bin.data());
      std::vector<std::string> copy = args;
      for (auto& a : copy) argv.push_back(a.data());
      argv.push_back(nullptr);
      ::execv(bin.c_str(), argv.data());
      ::_exit(127);
    }
  }
  ~ChildProcess() {
    if (running()) {
      ::kill(pid_, SIGKILL);
      Wait(std::chrono::seconds(5));
    }
  }
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  pid_t pid() const { return pid_; }
  bool running() {
    if (exit_code_) return false;
    int status = 0;
    const pid_t r = ::waitpid(pid_, &status, WNOHANG);
    if (r == pid_) {
      exit_code_ = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
      return false;
    }
    return r == 0;
  }
  // Exit code (128 + signal if killed), or nullopt if still running at the timeout.
  std::optional<int> Wait(std::chrono::milliseconds timeout) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (running()) {
      if (std::chrono::steady_clock::now() > deadline) return std::nullopt;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    return exit_code_;
  }
  void Signal(int signal) { ::kill(pid_, signal); }
  std::string Output() const {
    std::ifstream in(log_path_);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
  }

 private:
  pid_t pid_ = -1;
  std::filesystem::path log_path_;
  std::optional<int> exit_code_;
};

// Runs a binary to completion; returns its exit code (or -1 on timeout) and its output.
inline std::pair<int, std::string> RunToCompletion(const std::filesystem::path& binary,
                                                   const std::vector<std::string>& args,
                                                   const std::filesystem::path& log_path,
                                                   std::chrono::milliseconds timeout) {
  ChildProcess p(binary, args, log_path);
  const auto code = p.Wait(timeout);
  return {code.value_or(-1), p.Output()};
}

// A TCP port that is free right now (bound to port 0, then released).
inline int FreeTcpPort() {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  addr.sin_port = 0;
  ::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr));
  socklen_t len = sizeof(addr);
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len);
  const int port = ntohs(addr.sin_port);
  ::close(fd);
  return port;
}

}  // namespace epmap::process
