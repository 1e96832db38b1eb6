// The attribute streams of docs/FORMAT.md, "Attributes". One routine per kind of channel walks
// the points for both directions: the encoder passes the true values and gets the codes, the
// decoder gets the codes from the stream; both keep the same reconstructed values, so their
// predictions agree bit for bit.
#include "format/attribute_coder.hpp"

#include <algorithm>
#include <bit>
#include <cstdlib>

#include "core/varint.hpp"
#include "format/range_coder.hpp"

namespace sspc::codec {
namespace {

constexpr std::uint32_t kWindow = 64;
constexpr int kSpreadContexts = 4;
constexpr std::uint32_t kWideEscape = 0xFFFF;

// floor(a / b) for b > 0.
std::int64_t floor_div(std::int64_t a, std::int64_t b) {
  const std::int64_t q = a / b;
  return (a % b != 0 && a < 0) ? q - 1 : q;
}

// The quantised residual: sign(r) · floor((|r| + floor(s/2)) / s).
std::int32_t quantise_residual(std::int32_t r, std::int32_t s) {
  const std::int32_t a = (std::abs(r) + s / 2) / s;
  return r < 0 ? -a : a;
}

struct Reference {
  const std::uint32_t* index;
  int count;
};

std::int32_t predict(const std::vector<std::int32_t>& rec, Reference ref, std::int32_t first) {
  if (ref.count == 0) return first;
  std::int64_t sum = 0;
  for (int r = 0; r < ref.count; ++r) sum += rec[ref.index[r]];
  return static_cast<std::int32_t>(floor_div(2 * sum + ref.count, 2 * std::int64_t{ref.count}));
}

int spread_context(const std::vector<std::int32_t>& rec, Reference ref, std::int32_t step) {
  if (ref.count < 2) return 0;
  std::int32_t lo = rec[ref.index[0]], hi = lo;
  for (int r = 1; r < ref.count; ++r) {
    lo = std::min(lo, rec[ref.index[r]]);
    hi = std::max(hi, rec[ref.index[r]]);
  }
  const std::int32_t w = hi - lo;
  return w <= step ? 0 : w <= 4 * step ? 1 : w <= 16 * step ? 2 : 3;
}

void encode_wide(RangeEncoder& rc, ValueModel& m, std::uint32_t v) {
  if (v < kWideEscape) {
    m.encode(rc, v);
    return;
  }
  m.encode(rc, kWideEscape);
  rc.encode_direct(v - kWideEscape, 17);
}
std::uint32_t decode_wide(RangeDecoder& rc, ValueModel& m) {
  const std::uint32_t v = m.decode(rc);
  return v < kWideEscape ? v : kWideEscape + rc.decode_direct(17);
}

// A predicted, quantised component (colour's Y, Co, Cg or intensity): docs/FORMAT.md.
struct Component {
  std::int32_t lo, hi, first, step;
  std::array<ValueModel, kSpreadContexts> models{};
  std::vector<std::int32_t> rec;

  // Codes point i's value `v` (encoder) or decodes it (decoder, v ignored); returns the
  // reconstructed value.
  template <bool kEncode, typename Coder>
  std::int32_t code(Coder& rc, Reference ref, std::int32_t v) {
    const std::int32_t p = predict(rec, ref, first);
    ValueModel& m = models[static_cast<std::size_t>(spread_context(rec, ref, step))];
    std::int64_t q = 0;
    if constexpr (kEncode) {
      q = quantise_residual(v - p, step);
      encode_wide(rc, m, static_cast<std::uint32_t>(zigzag_encode(q)));
    } else {
      q = zigzag_decode(decode_wide(rc, m));
    }
    const auto value = static_cast<std::int32_t>(
        std::clamp<std::int64_t>(p + q * step, lo, hi));
    rec.push_back(value);
    return value;
  }
};

// A lossless symbol (classification, returns): "same as the first reference", else the value.
struct Symbol {
  std::array<std::uint16_t, 3> same;
  std::array<ValueModel, 3> models{};
  std::vector<std::int32_t> rec;
  Symbol() { same.fill(kProbabilityHalf); }

  template <bool kEncode, typename Coder>
  std::int32_t code(Coder& rc, Reference ref, std::int32_t v) {
    int ctx = 0;
    std::int32_t predicted = 0;
    if (ref.count > 0) {
      predicted = rec[ref.index[0]];
      ctx = 1;
      for (int r = 1; r < ref.count; ++r) ctx = rec[ref.index[r]] == predicted ? ctx : 2;
    }
    const auto c = static_cast<std::size_t>(ctx);
    std::int32_t value = 0;
    if constexpr (kEncode) {
      const bool hit = ref.count > 0 && v == predicted;
      if (ref.count > 0) rc.encode(same[c], hit ? 0u : 1u);
      if (!hit) models[c].encode(rc, static_cast<std::uint32_t>(v));
      value = v;
    } else {
      const bool hit = ref.count > 0 && rc.decode(same[c]) == 0;
      value = hit ? predicted : static_cast<std::int32_t>(models[c].decode(rc));
    }
    rec.push_back(value);
    return value;
  }
};

// YCoCg-R (docs/FORMAT.md, "Attributes", Colour).
std::array<std::int32_t, 3> to_ycocg(Rgb8 c) {
  const std::int32_t r = c.r, g = c.g, b = c.b;
  const std::int32_t co = r - b;
  const std::int32_t t = b + (co >> 1);
  const std::int32_t cg = g - t;
  return {t + (cg >> 1), co, cg};
}
Rgb8 from_ycocg(std::int32_t y, std::int32_t co, std::int32_t cg) {
  const std::int32_t t = y - (cg >> 1);
  const std::int32_t g = cg + t;
  const std::int32_t b = t - (co >> 1);
  const std::int32_t r = b + co;
  auto u8 = [](std::int32_t v) { return static_cast<std::uint8_t>(std::clamp(v, 0, 255)); };
  return {u8(r), u8(g), u8(b)};
}

// One walk per channel; `io` is the cloud read (encoder) or appended to (decoder).
template <bool kEncode, typename Coder, typename Io>
bool walk(std::uint8_t channel, const AttributeParams& params, const AttributeReferences& refs,
          Coder& rc, Io& io, std::size_t base) {
  const std::size_t n = refs.count.size();
  auto reference = [&](std::size_t i) { return Reference{refs.index[i].data(), refs.count[i]}; };
  auto overrun = [&] {
    if constexpr (kEncode) {
      return false;
    } else {
      return rc.overrun();
    }
  };
  const auto lengths = [&params](auto& models) {
    if (params.unary_lengths) {
      for (ValueModel& m : models) m.use_unary_lengths();
    }
  };
  if (channel == kChannelColour) {
    const std::int32_t s = params.colour_step;
    std::array<Component, 3> comp = {Component{0, 255, 128, s, {}, {}},
                                     Component{-255, 255, 0, s, {}, {}},
                                     Component{-255, 255, 0, s, {}, {}}};
    for (Component& c : comp) {
      c.rec.reserve(n);
      lengths(c.models);
    }
    for (std::size_t i = 0; i < n; ++i) {
      std::array<std::int32_t, 3> v{};
      if constexpr (kEncode) v = to_ycocg(io.colours[base + i]);
      std::array<std::int32_t, 3> out{};
      for (std::size_t k = 0; k < 3; ++k) out[k] = comp[k].template code<kEncode>(rc, reference(i), v[k]);
      if constexpr (!kEncode) io.colours.push_back(from_ycocg(out[0], out[1], out[2]));
      if (overrun()) return false;
    }
  } else if (channel == kChannelIntensity) {
    Component c{0, 65535, 0, params.intensity_step, {}, {}};
    c.rec.reserve(n);
    lengths(c.models);
    for (std::size_t i = 0; i < n; ++i) {
      std::int32_t v = 0;
      if constexpr (kEncode) v = io.las.intensity[base + i];
      const std::int32_t out = c.template code<kEncode>(rc, reference(i), v);
      if constexpr (!kEncode) io.las.intensity.push_back(static_cast<std::uint16_t>(out));
      if (overrun()) return false;
    }
  } else {
    const bool classes = channel == kChannelClassification;
    Symbol sym;
    sym.rec.reserve(n);
    lengths(sym.models);
    for (std::size_t i = 0; i < n; ++i) {
      std::int32_t v = 0;
      if constexpr (kEncode) {
        v = classes ? io.las.classification[base + i]
                    : 16 * io.las.return_number[base + i] + io.las.number_of_returns[base + i];
      }
      const std::int32_t out = sym.template code<kEncode>(rc, reference(i), v);
      if (out > 255 || overrun()) return false;
      if constexpr (!kEncode) {
        if (classes) {
          io.las.classification.push_back(static_cast<std::uint8_t>(out));
        } else {
          io.las.return_number.push_back(static_cast<std::uint8_t>(out >> 4));
          io.las.number_of_returns.push_back(static_cast<std::uint8_t>(out & 15));
        }
      }
    }
  }
  return true;
}

}  // namespace

int AttributeParams::channel_count() const { return std::popcount(static_cast<unsigned>(channels)); }

void AttributeReferences::find(std::span<const Vec3f> p) {
  const std::size_t n = p.size();
  index.assign(n, {0, 0, 0});
  count.assign(n, 0);
  for (std::size_t i = 0; i < n; ++i) {
    std::array<float, 3> best_d{};
    std::array<std::uint32_t, 3> best_j{};
    int k = 0;
    const std::size_t begin = i > kWindow ? i - kWindow : 0;
    // Candidates from the nearest in order back; a later one wins a tie, so insertion needs a
    // strictly smaller distance.
    for (std::size_t j = i; j-- > begin;) {
      const Vec3f e = p[j] - p[i];
      const float d = (e.x() * e.x() + e.y() * e.y()) + e.z() * e.z();
      if (k == 3 && !(d < best_d[2])) continue;
      int at = k < 3 ? k++ : 2;
      while (at > 0 && d < best_d[static_cast<std::size_t>(at - 1)]) {
        best_d[static_cast<std::size_t>(at)] = best_d[static_cast<std::size_t>(at - 1)];
        best_j[static_cast<std::size_t>(at)] = best_j[static_cast<std::size_t>(at - 1)];
        --at;
      }
      best_d[static_cast<std::size_t>(at)] = d;
      best_j[static_cast<std::size_t>(at)] = static_cast<std::uint32_t>(j);
    }
    index[i] = best_j;
    count[i] = static_cast<std::uint8_t>(k);
  }
}

std::string encode_attribute_stream(std::uint8_t channel, const AttributeParams& params,
                                    const AttributeReferences& refs, const PointCloud& values) {
  std::string out;
  RangeEncoder rc(out);
  walk<true>(channel, params, refs, rc, values, 0);
  rc.finish();
  return out;
}

Status decode_attribute_stream(std::uint8_t channel, const AttributeParams& params,
                               const AttributeReferences& refs, std::span<const std::byte> stream,
                               PointCloud& out) {
  RangeDecoder rc(stream);
  if (!walk<false>(channel, params, refs, rc, out, 0) || !rc.finish()) {
    return corrupt("attribute stream is malformed");
  }
  return Status();
}

std::uint8_t channels_present(const PointCloud& cloud) {
  std::uint8_t c = 0;
  if (cloud.has_colours()) c |= kChannelColour;
  if (!cloud.las.intensity.empty()) c |= kChannelIntensity;
  if (!cloud.las.classification.empty()) c |= kChannelClassification;
  if (!cloud.las.return_number.empty() && !cloud.las.number_of_returns.empty()) c |= kChannelReturns;
  return c;
}

}  // namespace sspc::codec
