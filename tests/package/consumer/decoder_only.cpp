// A downstream decoder: links sspc::decoder alone (no encoder, no renderer) and decodes one patch.
#include <sspc/compressed_model.hpp>

#include <cstdio>

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: decoder_only MODEL.sspc\n");
    return 2;
  }
  auto model = sspc::CompressedModel::open(argv[1]);
  if (!model.ok()) {
    std::fprintf(stderr, "%s\n", model.status().to_string().c_str());
    return 1;
  }
  auto patch = model->decode_patch(0);
  if (!patch.ok()) {
    std::fprintf(stderr, "%s\n", patch.status().to_string().c_str());
    return 1;
  }
  std::printf("decoded patch0=%zu\n", patch->size());
  return patch->size() > 0 ? 0 : 1;
}
