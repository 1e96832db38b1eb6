// Replays fuzz inputs through a target's LLVMFuzzerTestOneInput without libFuzzer, so that CTest
// runs every corpus file (seeds and past crashes) in the ordinary builds, sanitised or not.
// Usage: <target>_replay FILE_OR_DIRECTORY...  (directories: every regular file in them).
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size);

namespace {

bool replay(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) {
    std::fprintf(stderr, "cannot read %s\n", file.c_str());
    return false;
  }
  const std::vector<char> bytes{std::istreambuf_iterator<char>(in),
                                std::istreambuf_iterator<char>()};
  // A copy of exactly the file's size, so that ASan catches a read one past the end.
  std::vector<std::uint8_t> input(bytes.size());
  std::copy(bytes.begin(), bytes.end(), reinterpret_cast<char*>(input.data()));
  LLVMFuzzerTestOneInput(input.data(), input.size());
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::filesystem::path> files;
  for (int i = 1; i < argc; ++i) {
    const std::filesystem::path arg(argv[i]);
    if (std::filesystem::is_directory(arg)) {
      for (const auto& e : std::filesystem::directory_iterator(arg)) {
        if (e.is_regular_file()) files.push_back(e.path());
      }
    } else {
      files.push_back(arg);
    }
  }
  std::sort(files.begin(), files.end());
  if (files.empty()) {
    std::fprintf(stderr, "no inputs to replay\n");
    return 1;
  }
  for (const auto& f : files) {
    if (!replay(f)) return 1;
  }
  std::printf("replayed %zu inputs\n", files.size());
  return 0;
}
