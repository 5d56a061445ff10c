#pragma once
// Counter-based random numbers: every number a pixel uses is a pure function of
// (scene seed, frame, pixel, sample, dimension), so frames are bit-identical at any thread count
// and A-SVGF's gradient samples can re-shade a pixel with the previous frame's exact random
// numbers.
//
// Two kinds share one interface (get for one dimension, get2 for a pair):
// - independent: a hash per (key, dimension); the 1-spp frames and gradient samples always use it.
// - Owen-scrambled Sobol, for references only: a padded Sobol sampler after Burley 2020
//   ("Practical Hash-based Owen Scrambling", JCGT 9(4)) and pbrt-v4's PaddedSobolSampler. Each
//   dimension pair (and each lone dimension) takes the first two Sobol dimensions (one), with the
//   sample index shuffled by a nested uniform (Owen) scramble seeded per (pixel, replicate,
//   dimension) and the coordinates Owen-scrambled with independent seeds. Shuffling the index in
//   reversed-bit order keeps every power-of-two prefix a (0,m,2)-net (the net only looks at the
//   top m bits of each coordinate, which depend only on the index's low m bits), so any 2^m samples
//   of one replicate are stratified, and different dimensions are decorrelated ("padding").
//   A replicate number selects an independent randomisation: K replicates of n samples each give
//   K independent, unbiased estimates whose spread is an honest error estimate of their mean.
#include <cstdint>
#include <glm/vec2.hpp>

namespace arena {

inline uint64_t mix64(uint64_t z) {  // splitmix64 finaliser (Steele et al. 2014)
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return z ^ (z >> 31);
}

namespace sobol {

constexpr uint32_t reverseBits(uint32_t x) {
  x = __builtin_bswap32(x);  // bytes, then bits within each byte
  x = ((x >> 1) & 0x55555555u) | ((x & 0x55555555u) << 1);
  x = ((x >> 2) & 0x33333333u) | ((x & 0x33333333u) << 2);
  return ((x >> 4) & 0x0F0F0F0Fu) | ((x & 0x0F0F0F0Fu) << 4);
}

// Burley 2020, sec. 3: a Laine-Karras style hash in which each bit depends only on itself and
// lower bits; applied to bit-reversed values it is a nested uniform (Owen) scramble.
inline uint32_t laineKarrasPermutation(uint32_t x, uint32_t seed) {
  x += seed;
  x ^= x * 0x6c50b47cu;
  x ^= x * 0xb82f1e52u;
  x ^= x * 0xc7afe638u;
  x ^= x * 0x8d22f6e6u;
  return x;
}
inline uint32_t nestedUniformScramble(uint32_t x, uint32_t seed) {
  return reverseBits(laineKarrasPermutation(reverseBits(x), seed));
}

// Sobol dimension 1 (primitive polynomial x + 1, m_1 = 1: m_k = 2 m_{k-1} xor m_{k-1}, Bratley &
// Fox 1988; Joe & Kuo 2008's first entry). Column k is v_k = m_k / 2^k as a 32-bit fraction.
// The product of the generator matrix with an index, byte by byte: byteTable[b][x] is the xor of
// the columns 8b..8b+7 selected by the bits of x.
// reversedTable does the same for reverse(dimension1(reverse(x))) from the bytes of x: bit m of x
// is bit 31 - m of reverse(x), which selects column v_{31-m}, whose reversal it xors in.
struct Dimension1 {
  uint32_t v[32];
  uint32_t byteTable[4][256];
  uint32_t reversedTable[4][256];
  constexpr Dimension1() : v{}, byteTable{}, reversedTable{} {
    uint32_t m = 1;
    for (int k = 1; k <= 32; ++k) {
      v[k - 1] = m << (32 - k);
      m = (m << 1) ^ m;
    }
    for (int b = 0; b < 4; ++b)
      for (int x = 0; x < 256; ++x)
        for (int k = 0; k < 8; ++k)
          if (x & (1 << k)) {
            byteTable[b][x] ^= v[8 * b + k];
            reversedTable[b][x] ^= reverseBits(v[31 - (8 * b + k)]);
          }
  }
};
inline constexpr Dimension1 kDimension1{};

// Sobol dimension 0 is the van der Corput sequence (the identity matrix): the reversed index.
inline uint32_t dimension0(uint32_t index) {
  return reverseBits(index);
}
// The xor of table[b][byte b of x] over the four bytes: a GF(2) matrix product, a byte at a time.
inline uint32_t byteTableProduct(const uint32_t (&table)[4][256], uint32_t x) {
  return table[0][x & 0xFF] ^ table[1][(x >> 8) & 0xFF] ^ table[2][(x >> 16) & 0xFF] ^ table[3][x >> 24];
}
inline uint32_t dimension1(uint32_t index) {
  return byteTableProduct(kDimension1.byteTable, index);
}
// reverseBits(dimension1(reverseBits(x))), without the two reversals.
inline uint32_t reversedDimension1OfReversed(uint32_t x) {
  return byteTableProduct(kDimension1.reversedTable, x);
}

inline float toUnitFloat(uint32_t x) {
  return float(x >> 8) * (1.0f / 16777216.0f);
}

}  // namespace sobol

enum class SamplerKind : uint8_t { Independent, OwenSobol };

class Sampler {
 public:
  // An unset sampler (independent, key 0), to be assigned: the batch loop's slots.
  Sampler() = default;
  // Independent numbers for sample `sample` of a pixel.
  Sampler(uint32_t seed, uint32_t frame, uint32_t pixel, uint32_t sample) {
    key_ = mix64(mix64(mix64(uint64_t(seed) + 0x9e3779b97f4a7c15ull) ^ frame) ^
                 ((uint64_t(pixel) << 20) ^ uint64_t(sample)));
  }
  // Sample `index` of randomisation `replicate` of the padded Owen-scrambled Sobol sequence of a
  // pixel. Samples of one replicate are stratified together; replicates are independent.
  static Sampler owenSobol(uint32_t seed, uint32_t frame, uint32_t pixel, uint32_t replicate, uint32_t index) {
    Sampler s(0, 0, 0, 0);
    s.kind_ = SamplerKind::OwenSobol;
    s.key_ = mix64(mix64(mix64(mix64(uint64_t(seed) ^ 0x50b01d5a3c1e2f47ull) ^ frame) ^ pixel) ^ replicate);
    s.reversedIndex_ = sobol::reverseBits(index);
    return s;
  }

  // Sample `index` of this sampler's Sobol randomisation: owenSobol(seed, frame, pixel, replicate,
  // index) without hashing the replicate's key again (a reference draws hundreds per replicate).
  // Sobol samplers only: an independent sampler's numbers do not depend on the index set here.
  Sampler atIndex(uint32_t index) const {
    Sampler s = *this;
    s.reversedIndex_ = sobol::reverseBits(index);
    s.batch_ = nullptr;  // a batch holds other indices' numbers
    return s;
  }

  // A Sobol replicate's per-dimension hashes, which do not depend on the sample index: computed
  // once for the hundreds of samples a reference draws from one replicate instead of at every
  // draw. Dimensions from `count` on are hashed on demand; the numbers are the same bits either way.
  static constexpr uint32_t kMaxHashedDims = 64;
  struct DimensionHashes {
    uint32_t count = 0;
    uint64_t dim[kMaxHashedDims];     // hash(d)
    uint32_t second[kMaxHashedDims];  // the seed of get2's second coordinate, uint32_t(mix64(hash(d)))
  };
  // This sampler reading dimensions 0..count-1 (at most kMaxHashedDims) from `table`, which it fills;
  // samplers made from it with atIndex share the table, which must outlive them.
  Sampler withHashes(DimensionHashes& table, uint32_t count) const {
    table.count = count < kMaxHashedDims ? count : kMaxHashedDims;
    for (uint32_t d = 0; d < table.count; ++d) {
      table.dim[d] = hash(d);
      table.second[d] = uint32_t(mix64(table.dim[d]));
    }
    Sampler s = *this;
    s.hashes_ = &table;
    s.batch_ = nullptr;
    return s;
  }

  // A Sobol replicate's numbers for up to kBatchLanes consecutive sample indices at once, for the
  // dimensions a path reads (FrameScene::sobolReads): a path's numbers are a chain of dependent
  // integer multiplies (three Laine-Karras permutations per pair), which a path waits on at each
  // vertex; filled for a batch of samples the lanes are independent, the loops vectorise, and a
  // path only loads its numbers. The same integer operations as get and get2: the same bits.
  static constexpr uint32_t kBatchLanes = 16;
  // The dimensions a batch holds: bit d of `pairs` for a pair (d, d + 1) read with get2, bit d of
  // `singles` for a dimension read with get; dimensions below kMaxHashedDims only.
  struct Reads {
    uint64_t pairs = 0, singles = 0;
  };
  struct Batch {
    static constexpr uint8_t kAbsent = 0xFF;
    uint8_t row[kMaxHashedDims];  // dimension -> its row of first (and second), or kAbsent
    uint64_t pairs = 0;           // the dimensions whose second coordinate is held too
    uint32_t rows = 0;
    float first[kMaxHashedDims][kBatchLanes];   // get(d), the first coordinate of get2(d)
    float second[kMaxHashedDims][kBatchLanes];  // get2(d)'s second coordinate (pairs only)
  };
  // Fills `batch` with this replicate's numbers (a sampler from withHashes, whose table covers
  // the reads) for samples firstIndex .. firstIndex + kBatchLanes - 1.
  void fillBatch(Batch& batch, Reads reads, uint32_t firstIndex) const {
    uint32_t reversed[kBatchLanes], x[kBatchLanes];
    for (uint32_t l = 0; l < kBatchLanes; ++l) reversed[l] = sobol::reverseBits(firstIndex + l);
    batch.rows = 0;
    batch.pairs = reads.pairs;
    const uint64_t any = reads.pairs | reads.singles;
    for (uint32_t d = 0; d < kMaxHashedDims; ++d) {
      batch.row[d] = Batch::kAbsent;
      if (!((any >> d) & 1) || !hashes_ || d >= hashes_->count) continue;
      const uint32_t r = batch.rows++;
      batch.row[d] = uint8_t(r);
      const uint64_t h = hashes_->dim[d];
      const uint32_t shuffle = uint32_t(h), scramble = uint32_t(h >> 32);
      for (uint32_t l = 0; l < kBatchLanes; ++l) {
        x[l] = sobol::laineKarrasPermutation(reversed[l], shuffle);
        batch.first[r][l] = sobol::toUnitFloat(
            sobol::reverseBits(sobol::laineKarrasPermutation(sobol::reverseBits(x[l]), scramble)));
      }
      if (!((reads.pairs >> d) & 1)) continue;
      const uint32_t seed = hashes_->second[d];
      for (uint32_t l = 0; l < kBatchLanes; ++l)
        batch.second[r][l] = sobol::toUnitFloat(sobol::reverseBits(
            sobol::laineKarrasPermutation(sobol::reversedDimension1OfReversed(x[l]), seed)));
    }
  }
  // Sample firstIndex + lane (lane < kBatchLanes) of the batch (this replicate's): reads its
  // numbers from the batch where it holds the dimension, computes them otherwise. The batch must
  // outlive the sampler.
  Sampler inBatch(const Batch& batch, uint32_t firstIndex, uint32_t lane) const {
    Sampler s = atIndex(firstIndex + lane);
    s.batch_ = &batch;
    s.lane_ = lane;
    return s;
  }

  SamplerKind kind() const { return kind_; }
  // Uniform in [0, 1) for dimension `dim`. Sobol: the value is
  //   nestedUniformScramble(dimension0(i), h_hi) with i = nestedUniformScramble(index, h_lo),
  // computed with the bit reversals that cancel left out (reversedShuffledIndex, firstCoordinate).
  float get(uint32_t dim) const {
    if (kind_ == SamplerKind::Independent) return sobol::toUnitFloat(uint32_t(hash(dim) >> 32));
    if (batch_ && dim < kMaxHashedDims && batch_->row[dim] != Batch::kAbsent)
      return batch_->first[batch_->row[dim]][lane_];
    const uint64_t h = hashed(dim);
    return firstCoordinate(reversedShuffledIndex(h), h);
  }
  // Uniform in [0, 1)^2 for dimensions (dim, dim + 1); stratified jointly by the Sobol sampler (the
  // first coordinate as in get, the second nestedUniformScramble(dimension1(i), mix64(h)), whose
  // inner reverse(dimension1(reverse(x))) is one table lookup).
  glm::vec2 get2(uint32_t dim) const {
    if (kind_ == SamplerKind::Independent) return {get(dim), get(dim + 1)};
    if (batch_ && dim < kMaxHashedDims && ((batch_->pairs >> dim) & 1) &&
        batch_->row[dim] != Batch::kAbsent) {
      const uint32_t r = batch_->row[dim];
      return {batch_->first[r][lane_], batch_->second[r][lane_]};
    }
    const uint64_t h = hashed(dim);
    const uint32_t x = reversedShuffledIndex(h);
    const uint32_t seed = inTable(dim) ? hashes_->second[dim] : uint32_t(mix64(h));
    const uint32_t second = sobol::laineKarrasPermutation(sobol::reversedDimension1OfReversed(x), seed);
    return {firstCoordinate(x, h), sobol::toUnitFloat(sobol::reverseBits(second))};
  }
  uint64_t key() const { return key_; }

 private:
  uint64_t hash(uint32_t dim) const { return mix64(key_ ^ (uint64_t(dim) * 0x9e3779b97f4a7c15ull)); }
  // (dim < kMaxHashedDims, implied by count, is written out for the compiler's bounds analysis.)
  bool inTable(uint32_t dim) const {
    return hashes_ && dim < kMaxHashedDims && dim < hashes_->count;
  }
  uint64_t hashed(uint32_t dim) const { return inTable(dim) ? hashes_->dim[dim] : hash(dim); }
  // x = reverse(i), i the index under dimension hash h's nested uniform shuffle.
  uint32_t reversedShuffledIndex(uint64_t h) const {
    return sobol::laineKarrasPermutation(reversedIndex_, uint32_t(h));
  }
  // nestedUniformScramble(dimension0(i), h_hi), where dimension0(i) = reverse(i) = x.
  static float firstCoordinate(uint32_t x, uint64_t h) {
    const uint32_t i = sobol::reverseBits(x);
    return sobol::toUnitFloat(sobol::reverseBits(sobol::laineKarrasPermutation(i, uint32_t(h >> 32))));
  }

  uint64_t key_ = 0;
  const DimensionHashes* hashes_ = nullptr;  // Sobol: this replicate's, where withHashes set them
  const Batch* batch_ = nullptr;             // Sobol: this sample's batch, where inBatch set it
  uint32_t lane_ = 0;                        // its lane there
  uint32_t reversedIndex_ = 0;  // Sobol: the sample index, bit-reversed (every dimension's shuffle starts there)
  SamplerKind kind_ = SamplerKind::Independent;
};

}  // namespace arena
