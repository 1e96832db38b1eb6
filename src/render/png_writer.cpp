// PNG through libpng: 8-bit RGB written into memory and then an atomic file write; any PNG read
// back as 8-bit RGB (what `sspc render --compare` compares); and the comparison of two images.
#include <png.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <string>

#include "core/atomic_file.hpp"
#include "sspc/render.hpp"

namespace sspc {

namespace {

void append(png_structp png, png_bytep data, png_size_t length) {
  auto* out = static_cast<std::string*>(png_get_io_ptr(png));
  out->append(reinterpret_cast<const char*>(data), length);
}
void flush(png_structp) {}

// libpng's errors become the Status of the call (through its longjmp), and its warnings are of
// no use to a caller: neither goes to stderr.
[[noreturn]] void on_error(png_structp png, png_const_charp) { png_longjmp(png, 1); }
void on_warning(png_structp, png_const_charp) {}

}  // namespace

Status write_png(const Image& image, const std::filesystem::path& path) {
  if (image.width < 1 || image.height < 1 ||
      image.rgb.size() != static_cast<std::size_t>(image.width) * static_cast<std::size_t>(image.height) * 3) {
    return invalid_argument("write_png: the image's size and pixels disagree");
  }
  std::string bytes;
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, on_error, on_warning);
  if (png == nullptr) return resource_exhausted("libpng: cannot create a write struct");
  png_infop info = png_create_info_struct(png);
  if (info == nullptr || setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    return internal_error("libpng failed to encode the image");
  }
  png_set_write_fn(png, &bytes, append, flush);
  png_set_IHDR(png, info, static_cast<png_uint_32>(image.width), static_cast<png_uint_32>(image.height), 8,
               PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  for (int y = 0; y < image.height; ++y) {
    png_write_row(png, image.rgb.data() + static_cast<std::size_t>(y) * static_cast<std::size_t>(image.width) * 3);
  }
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  return write_file_atomically(path, std::as_bytes(std::span<const char>(bytes.data(), bytes.size())));
}

StatusOr<Image> read_png(const std::filesystem::path& path) {
  const std::string name = path.string();
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> file(std::fopen(path.c_str(), "rb"), std::fclose);
  if (file == nullptr) return not_found(name + ": cannot open");
  png_byte signature[8];
  if (std::fread(signature, 1, 8, file.get()) != 8 || png_sig_cmp(signature, 0, 8) != 0) {
    return invalid_argument(name + ": not a PNG file");
  }
  png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, nullptr, on_error, on_warning);
  if (png == nullptr) return resource_exhausted("libpng: cannot create a read struct");
  png_infop info = png_create_info_struct(png);
  Image image;
  // libpng reports errors by longjmp: nothing with a destructor may be created after setjmp.
  std::vector<png_bytep> rows;
  if (info == nullptr || setjmp(png_jmpbuf(png))) {
    png_destroy_read_struct(&png, &info, nullptr);
    return invalid_argument(name + ": a corrupt or truncated PNG");
  }
  png_init_io(png, file.get());
  png_set_sig_bytes(png, 8);
  png_read_info(png, info);
  const png_uint_32 width = png_get_image_width(png, info), height = png_get_image_height(png, info);
  if (width < 1 || height < 1 || width > 65536 || height > 65536) {
    png_destroy_read_struct(&png, &info, nullptr);
    return invalid_argument(name + ": the PNG's size is outside 1..65536 pixels a side");
  }
  // Whatever it stores, as 8-bit RGB.
  png_set_strip_16(png);
  png_set_strip_alpha(png);
  png_set_packing(png);
  png_set_palette_to_rgb(png);
  png_set_expand_gray_1_2_4_to_8(png);
  png_set_gray_to_rgb(png);
  png_set_interlace_handling(png);
  png_read_update_info(png, info);
  if (png_get_rowbytes(png, info) != static_cast<png_size_t>(width) * 3) {
    png_destroy_read_struct(&png, &info, nullptr);
    return invalid_argument(name + ": a PNG layout that does not convert to 8-bit RGB");
  }
  image.width = static_cast<int>(width);
  image.height = static_cast<int>(height);
  image.rgb.resize(static_cast<std::size_t>(width) * height * 3);
  rows.resize(height);
  for (png_uint_32 y = 0; y < height; ++y) rows[y] = image.rgb.data() + static_cast<std::size_t>(y) * width * 3;
  png_read_image(png, rows.data());
  png_read_end(png, nullptr);
  png_destroy_read_struct(&png, &info, nullptr);
  return image;
}

namespace {

// `image` box-filtered by `factor` in each direction: each pixel the mean of its factor² pixels,
// misses (black) included, rounded.
Image box_filtered(const Image& image, int factor) {
  Image out;
  out.width = image.width / factor;
  out.height = image.height / factor;
  out.rgb.resize(3 * static_cast<std::size_t>(out.width) * static_cast<std::size_t>(out.height));
  const double area = static_cast<double>(factor) * static_cast<double>(factor);
  for (int y = 0; y < out.height; ++y) {
    for (int x = 0; x < out.width; ++x) {
      double sum[3] = {0, 0, 0};
      for (int v = 0; v < factor; ++v) {
        for (int u = 0; u < factor; ++u) {
          const std::size_t i = 3 * (static_cast<std::size_t>(y * factor + v) * static_cast<std::size_t>(image.width) +
                                     static_cast<std::size_t>(x * factor + u));
          for (int k = 0; k < 3; ++k) sum[k] += image.rgb[i + static_cast<std::size_t>(k)];
        }
      }
      const std::size_t o = 3 * (static_cast<std::size_t>(y) * static_cast<std::size_t>(out.width) + static_cast<std::size_t>(x));
      for (int k = 0; k < 3; ++k) out.rgb[o + static_cast<std::size_t>(k)] = static_cast<std::uint8_t>(std::lround(sum[k] / area));
    }
  }
  return out;
}

}  // namespace

StatusOr<ImageComparison> compare_images(const Image& first, const Image& second) {
  const auto pixels = static_cast<std::size_t>(first.width) * static_cast<std::size_t>(first.height);
  const auto size_of = [](const Image& i) { return std::to_string(i.width) + "x" + std::to_string(i.height); };
  if (first.rgb.size() != 3 * pixels ||
      second.rgb.size() != 3 * static_cast<std::size_t>(second.width) * static_cast<std::size_t>(second.height)) {
    return invalid_argument("an image's pixels do not match its size");
  }
  // A reference rendered k times larger each way is compared box-filtered (supersampled).
  if (first.width > 0 && first.height > 0 && second.width != first.width && second.width % first.width == 0 &&
      second.width / first.width == second.height / first.height && second.height % first.height == 0) {
    return compare_images(first, box_filtered(second, second.width / first.width));
  }
  if (first.width != second.width || first.height != second.height) {
    return invalid_argument("the images differ in size (" + size_of(first) + " and " + size_of(second) +
                            "), and the second is not the first's size times a whole number");
  }
  ImageComparison c;
  c.pixels = pixels;
  double squared = 0;
  for (std::size_t i = 0; i < pixels; ++i) {
    const std::uint8_t* a = &first.rgb[3 * i];
    const std::uint8_t* b = &second.rgb[3 * i];
    const bool hit_a = (a[0] | a[1] | a[2]) != 0, hit_b = (b[0] | b[1] | b[2]) != 0;
    if (hit_a && hit_b) {
      ++c.hit_both;
      for (int k = 0; k < 3; ++k) {
        const double e = static_cast<double>(a[k]) - static_cast<double>(b[k]);
        squared += e * e;
      }
    } else if (hit_a) {
      ++c.hit_first_only;
    } else if (hit_b) {
      ++c.hit_second_only;
    }
  }
  if (c.hit_both == 0) return c;
  const double mse = squared / (3.0 * static_cast<double>(c.hit_both));
  c.psnr_hit = mse > 0 ? 10.0 * std::log10(255.0 * 255.0 / mse) : std::numeric_limits<double>::infinity();
  return c;
}

}  // namespace sspc
