// References: the Owen-scrambled Sobol sampler's stratification, honest replicate variance,
// refinement and thread-count determinism, the cap warning and its record in sequence.json.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <regex>
#include <set>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/json_reader.hpp"
#include "core/sequence.hpp"
#include "harness/reference_quality.hpp"
#include "harness/study.hpp"
#include "metrics/error.hpp"
#include "metrics/metric_registry.hpp"
#include "tests/test_util.hpp"
#include "tracer/render.hpp"
#include "tracer/sampler.hpp"

namespace arena {
namespace {

TEST(Sobol, UnscrambledDimensionsAreTheKnownSequences) {
  // Joe & Kuo's dimension 2 in index order (not Gray-code order): x_i = xor of v_k over i's set
  // bits.
  const double expected1[8] = {0, 0.5, 0.75, 0.25, 0.625, 0.125, 0.375, 0.875};
  const double expected0[8] = {0, 0.5, 0.25, 0.75, 0.125, 0.625, 0.375, 0.875};  // van der Corput
  for (uint32_t i = 0; i < 8; ++i) {
    EXPECT_DOUBLE_EQ(sobol::dimension1(i) * 0x1p-32, expected1[i]) << i;
    EXPECT_DOUBLE_EQ(sobol::dimension0(i) * 0x1p-32, expected0[i]) << i;
  }
}

// The sampler computes its values without the bit reversals that cancel; they must be the values
// of the definition (tracer/sampler.hpp): i = nestedUniformScramble(index, h_lo), then
// nestedUniformScramble(dimension0(i), h_hi) and nestedUniformScramble(dimension1(i), mix64(h)),
// with h = mix64(key ^ dim x the golden-ratio constant).
TEST(Sobol, ShortcutsGiveTheDefinitionsBits) {
  for (uint32_t x : {0u, 1u, 0x80000000u, 0xdeadbeefu, 0x12345678u, 0xffffffffu})
    EXPECT_EQ(sobol::reversedDimension1OfReversed(x),
              sobol::reverseBits(sobol::dimension1(sobol::reverseBits(x))))
        << x;
  for (uint32_t pixel : {0u, 4242u})
    for (uint32_t index : {0u, 1u, 7u, 1000u, 65535u})
      for (uint32_t dim : {0u, 5u, 21u}) {
        const Sampler s = Sampler::owenSobol(9, 2, pixel, 3, index);
        const uint64_t h = mix64(s.key() ^ (uint64_t(dim) * 0x9e3779b97f4a7c15ull));
        const uint32_t i = sobol::nestedUniformScramble(index, uint32_t(h));
        const float u0 = sobol::toUnitFloat(sobol::nestedUniformScramble(sobol::dimension0(i), uint32_t(h >> 32)));
        const float u1 = sobol::toUnitFloat(sobol::nestedUniformScramble(sobol::dimension1(i), uint32_t(mix64(h))));
        EXPECT_EQ(s.get(dim), u0) << pixel << " " << index << " " << dim;
        EXPECT_EQ(s.get2(dim).x, u0);
        EXPECT_EQ(s.get2(dim).y, u1);
      }
}

TEST(Sobol, ScramblingIsABijectionOnEveryPrefix) {
  // A nested uniform scramble maps [k 2^m, (k+1) 2^m) / 2^32 intervals onto such intervals.
  std::set<uint32_t> top;
  for (uint32_t i = 0; i < 256; ++i) top.insert(sobol::nestedUniformScramble(i << 24, 12345u) >> 24);
  EXPECT_EQ(top.size(), 256u);
}

// Every power-of-two prefix of one replicate is a (0,m,2)-net in each dimension pair and
// stratified in each lone dimension, whatever the pixel, replicate and dimension.
TEST(Sobol, EveryPrefixOfAReplicateIsA02Net) {
  for (uint32_t pixel : {0u, 977u}) {
    for (uint32_t replicate : {0u, 5u}) {
      for (uint32_t dim : {0u, 2u, 13u}) {
        for (int m = 1; m <= 8; ++m) {
          const uint32_t n = 1u << m;
          for (int a = 0; a <= m; ++a) {
            std::set<std::pair<int, int>> cells;
            std::set<int> strata;
            for (uint32_t k = 0; k < n; ++k) {
              const Sampler s = Sampler::owenSobol(7, 3, pixel, replicate, k);
              const glm::vec2 u = s.get2(dim);
              ASSERT_TRUE(u.x >= 0 && u.x < 1 && u.y >= 0 && u.y < 1);
              cells.insert({int(u.x * float(1 << a)), int(u.y * float(1 << (m - a)))});
              strata.insert(int(s.get(dim + 2) * float(n)));
            }
            EXPECT_EQ(cells.size(), n) << "pixel " << pixel << " replicate " << replicate << " dim " << dim << " m "
                                       << m << " a " << a;
            EXPECT_EQ(strata.size(), n) << "1D, dim " << dim + 2 << " m " << m;
          }
        }
      }
    }
  }
}

// A replicate's sampler moved to another index (the reference loop hashes each replicate's key
// once) is that index's sampler, bit for bit.
TEST(Sobol, AReplicatesSamplerAtAnotherIndexIsThatIndexsSampler) {
  for (uint32_t index : {0u, 1u, 3u, 1000u})
    for (uint32_t dim : {0u, 2u, 13u}) {
      const Sampler moved = Sampler::owenSobol(1, 0, 10, 2, 7).atIndex(index), fresh = Sampler::owenSobol(1, 0, 10, 2, index);
      EXPECT_EQ(moved.get2(dim), fresh.get2(dim)) << index << " " << dim;
      EXPECT_EQ(moved.get(dim), fresh.get(dim)) << index << " " << dim;
    }
}

// A replicate's dimension hashes computed once (the reference loop) give every dimension's
// numbers bit for bit, inside the table and beyond it (hashed on demand).
TEST(Sobol, AReplicatesPrecomputedDimensionHashesGiveTheSameNumbers) {
  Sampler::DimensionHashes table;
  const Sampler base = Sampler::owenSobol(3, 1, 77, 5, 0);
  const Sampler hashed = base.withHashes(table, 24);
  EXPECT_EQ(table.count, 24u);
  for (uint32_t index : {0u, 1u, 6u, 511u, 4097u})
    for (uint32_t dim = 0; dim < 40; ++dim) {
      const Sampler a = hashed.atIndex(index), b = base.atIndex(index);
      EXPECT_EQ(a.get2(dim), b.get2(dim)) << index << " " << dim;
      EXPECT_EQ(a.get(dim), b.get(dim)) << index << " " << dim;
    }
  Sampler::DimensionHashes capped;
  base.withHashes(capped, 1000);
  EXPECT_EQ(capped.count, Sampler::kMaxHashedDims);
}

// A batch of samples' numbers (the reference loop fills kBatchLanes at a time) are each lane's
// sampler's numbers bit for bit: pairs and lone dimensions it holds, a pair's first coordinate read
// alone, a lone dimension read as a pair (computed: the batch has no second coordinate for it),
// and dimensions it does not hold or the hash table does not cover (computed on demand).
TEST(Sobol, ABatchOfSamplesGivesEachSamplesOwnNumbers) {
  Sampler::DimensionHashes table;
  const Sampler base = Sampler::owenSobol(9, 2, 501, 1, 0);
  const Sampler hashed = base.withHashes(table, 24);
  Sampler::Reads reads;
  reads.pairs = (1ull << 2) | (1ull << 5) | (1ull << 13) | (1ull << 30) |
                (1ull << 63);  // 30, 63: beyond the table
  reads.singles = (1ull << 7) | (1ull << 23);
  Sampler::Batch batch;
  for (uint32_t first : {0u, 16u, 4090u, 100000u}) {
    hashed.fillBatch(batch, reads, first);
    EXPECT_EQ(batch.rows, 5u);  // 2, 5, 7, 13, 23
    for (uint32_t lane = 0; lane < Sampler::kBatchLanes; ++lane) {
      const Sampler a = hashed.inBatch(batch, first, lane), b = base.atIndex(first + lane);
      for (uint32_t dim = 0; dim < 40; ++dim) {
        EXPECT_EQ(a.get2(dim), b.get2(dim)) << first << " " << lane << " " << dim;
        EXPECT_EQ(a.get(dim), b.get(dim)) << first << " " << lane << " " << dim;
      }
      for (uint32_t dim : {62u, 63u, 64u, 65u, 1u << 20}) {  // the last: the specular ray's pair
        EXPECT_EQ(a.get2(dim), b.get2(dim)) << first << " " << lane << " " << dim;
        EXPECT_EQ(a.get(dim), b.get(dim)) << first << " " << lane << " " << dim;
      }
      // Moved to another index, or given hashes again, a sampler leaves the batch (whose numbers
      // are other indices').
      EXPECT_EQ(a.atIndex(first + lane + 1).get2(2), base.atIndex(first + lane + 1).get2(2));
      Sampler::DimensionHashes again;
      EXPECT_EQ(a.withHashes(again, 24).atIndex(5).get2(5), base.atIndex(5).get2(5));
    }
  }
  // The lanes are the samples first .. first + 15, in order (not a permutation of them).
  hashed.fillBatch(batch, reads, 32);
  EXPECT_EQ(batch.first[batch.row[2]][3], base.atIndex(35).get(2));
  EXPECT_NE(batch.first[batch.row[2]][3], base.atIndex(36).get(2));
}

TEST(Sobol, ReplicatesAndPixelsAreDecorrelated) {
  // Different replicates (and pixels) must not repeat each other's points.
  const glm::vec2 a = Sampler::owenSobol(1, 0, 10, 0, 3).get2(2);
  EXPECT_NE(a, Sampler::owenSobol(1, 0, 10, 1, 3).get2(2));
  EXPECT_NE(a, Sampler::owenSobol(1, 0, 11, 0, 3).get2(2));
  EXPECT_NE(a, Sampler::owenSobol(1, 0, 10, 0, 3).get2(5));
  // The independent sampler's pair is exactly its two single dimensions (frames are unchanged).
  const Sampler ind(1, 0, 10, 3);
  EXPECT_EQ(ind.get2(5), glm::vec2(ind.get(5), ind.get(6)));
}

RenderSettings referenceSettings(const std::string& sampler, int spp) {
  RenderSettings s = test::tinySettings(32, 18, 1, spp);
  s.referenceSampler = sampler;
  return s;
}

// Mean over pixels and channels of ((a - b)^2 - varB) / (b^2 + eps): a's error against b,
// corrected for b's own noise.
double trueRelMse(const LayerSet& a, const LayerSet& gold) {
  return linearError(a.get("color"), gold.get("color"), &gold.get("colorVar")).relMseCorrected;
}

// The replicate variance predicts the measured error of the mean (Sobol, where the per-sample
// variance would overstate it): cornell_static at 32x18, 64 spp (4 replicates of 16) against a
// gold of 16x the samples under another seed (withIndependentSeed: a gold holding the reference's
// own samples would flatter it by about 2 x 1/16). Tolerance: the measured/predicted ratio within
// [0.7, 1.4] (the estimate averages 1728 values of 3 degrees of freedom each; the measurement is
// one draw).
TEST(Reference, ReplicateVariancePredictsTheTrueError) {
  const Scene scene = test::shippedScene("cornell_static");
  RayCounts counts;
  SequenceRenderer goldRenderer(withIndependentSeed(scene), referenceSettings("sobol", 1024));
  ReferenceSums goldSums;
  goldRenderer.extendReference(0, goldSums, 128, counts);
  const LayerSet gold = referenceLayersFromSums(goldSums);
  EXPECT_NE(withIndependentSeed(scene).seed, scene.seed);
  EXPECT_EQ(withIndependentSeed(scene).name, scene.name);
  for (const std::string sampler : {"sobol", "independent"}) {
    SequenceRenderer r(scene, referenceSettings(sampler, 64));
    const ReferenceResult ref = r.renderReference(0);
    ASSERT_EQ(ref.spp, 64);
    const double predicted = ref.estimatedRelMse, measured = trueRelMse(ref.layers, gold);
    EXPECT_NEAR(predicted, referenceRelMse(ref.layers.get("color"), ref.layers.get("colorVar")), 1e-3 * predicted);
    EXPECT_GT(measured / predicted, 0.7) << sampler << ": predicted " << predicted << " measured " << measured;
    EXPECT_LT(measured / predicted, 1.4) << sampler << ": predicted " << predicted << " measured " << measured;
  }
}

// At 32 samples per replicate (256 spp) the Sobol reference's (honest) error is below the
// independent one's. Measured: see `arena bench reference` for the size of the gain.
TEST(Reference, SobolBeatsIndependentAtEqualSamples) {
  const Scene scene = test::shippedScene("cornell_static");
  SequenceRenderer sobol(scene, referenceSettings("sobol", 256)),
      independent(scene, referenceSettings("independent", 256));
  const double s = sobol.renderReference(0).estimatedRelMse, i = independent.renderReference(0).estimatedRelMse;
  EXPECT_LT(s, i) << "sobol " << s << " independent " << i;
}

TEST(Reference, ExtendingGivesTheSameBitsAsRenderingAtOnce) {
  const Scene scene = test::shippedScene("moving_object");
  SequenceRenderer r(scene, referenceSettings("sobol", 32));
  RayCounts counts;
  ReferenceSums once, extended;
  r.extendReference(0, once, 4, counts);
  r.extendReference(0, extended, 1, counts);
  r.extendReference(0, extended, 3, counts);
  r.extendReference(0, extended, 4, counts);
  EXPECT_EQ(once.sum, extended.sum);
  EXPECT_EQ(once.spp(), 4 * r.referenceReplicates());
}

// A scene's reference (frame 0, adaptive below its cap) rendered on one thread and on two, under
// either sampler: every layer the same bits, and the same error estimate.
void expectReferencesBitIdenticalAtOneAndTwoThreads(const std::string& sceneName, int spp,
                                                    int minSpp, double relError) {
  const Scene scene = test::shippedScene(sceneName);
  for (const std::string sampler : {"sobol", "independent"}) {
    auto render = [&](int threads) {
      tbb::global_control limit(tbb::global_control::max_allowed_parallelism, size_t(threads));
      RenderSettings s = referenceSettings(sampler, spp);
      s.referenceMinSpp = minSpp;
      s.referenceRelError = relError;
      return SequenceRenderer(scene, s).renderReference(0);
    };
    const ReferenceResult one = render(1), two = render(2);
    if (sampler == "sobol") {
      EXPECT_LT(one.sppMin, one.sppMax)
          << sceneName << ": the allocation should differ between tiles";
    }
    for (const auto& [name, img] : one.layers.all())
      EXPECT_TRUE(samePixels(img, two.layers.get(name)))
          << sceneName << " " << sampler << " layer " << name;
    EXPECT_EQ(one.estimatedRelMse, two.estimatedRelMse) << sceneName << " " << sampler;
  }
}

TEST(Reference, BitIdenticalAtAnyThreadCount) {
  // relMSE 4e-4: a few adaptive rounds, below the cap.
  expectReferencesBitIdenticalAtOneAndTwoThreads("moving_object", 256, 16, 0.02);
}

// hard_light's bidirectional references against path-traced ones of the same frame: each layer's
// tiles of 8x8 agree within their combined replicate noise (mean z near 0, mean z^2 near 1), the
// images' means within 1%; and at a quarter of the samples the bidirectional estimate's own
// error is lower (the reason the scene asks for it: docs/references.md).
TEST(Reference, BidirectionalAgreesWithThePathTracer) {
  Scene bidirectional = test::shippedScene("hard_light");
  ASSERT_EQ(bidirectional.referenceEstimator, ReferenceEstimator::Bidirectional);
  Scene path = bidirectional;
  path.referenceEstimator = ReferenceEstimator::Path;
  RenderSettings s = test::tinySettings(64, 36, 1, 1024);
  s.referenceRelError = 0;
  const ReferenceResult gold = SequenceRenderer(path, s).renderReference(0);
  s.referenceSpp = 256;
  const ReferenceResult bd = SequenceRenderer(bidirectional, s).renderReference(0);
  std::printf("estimated relMSE: path 1024 spp %.3g, bidirectional 256 spp %.3g\n",
              gold.estimatedRelMse, bd.estimatedRelMse);
  EXPECT_LT(bd.estimatedRelMse, gold.estimatedRelMse)
      << "256 bidirectional samples against 1024 path-traced ones";
  for (const char* layer : {"color", "diffuse", "specular"}) {
    const Image &a = gold.layers.get(layer), &va = gold.layers.get(std::string(layer) + "Var");
    const Image &b = bd.layers.get(layer), &vb = bd.layers.get(std::string(layer) + "Var");
    double sumA = 0, sumB = 0, sumZ = 0, sumZ2 = 0;
    int tiles = 0;
    for (int c = 0; c < 3; ++c)
      for (int ty = 0; ty < 36; ty += 8)
        for (int tx = 0; tx < 64; tx += 8) {
          double d = 0, v = 0;
          for (int y = ty; y < std::min(ty + 8, 36); ++y)
            for (int x = tx; x < tx + 8; ++x) {
              d += double(a.at(x, y, c)) - double(b.at(x, y, c));
              v += double(va.at(x, y, c)) + double(vb.at(x, y, c));
              sumA += a.at(x, y, c);
              sumB += b.at(x, y, c);
            }
          if (!(v > 0)) continue;
          const double z = d / std::sqrt(v);
          sumZ += z;
          sumZ2 += z * z;
          ++tiles;
        }
    std::printf("%s: mean ratio %.5f, tiles %d, sum z / sqrt(n) %.3f, mean z^2 %.3f\n", layer,
                sumB / sumA, tiles, sumZ / std::sqrt(double(tiles)), sumZ2 / tiles);
    ASSERT_GT(tiles, 100) << layer;
    EXPECT_NEAR(sumB / sumA, 1.0, 0.01) << layer;
    EXPECT_LT(std::abs(sumZ / std::sqrt(double(tiles))), 4.0) << layer;
    EXPECT_GT(sumZ2 / tiles, 0.5) << layer;
    EXPECT_LT(sumZ2 / tiles, 2.0) << layer;
  }
}

TEST(Reference, BidirectionalBitIdenticalAtAnyThreadCount) {
  expectReferencesBitIdenticalAtOneAndTwoThreads("hard_light", 128, 8, 0.05);
}

// Two 8x8 tiles whose replicate means spread by a and 4a: the per-sample error of the second is
// 16x the first's, so the Neyman allocation gives it sqrt(16) = 4x the samples per pixel.
ReferenceSums twoTileSums(double spread0, double spread1, int n0, int n1) {
  ReferenceSums s;
  s.width = 16;
  s.height = 8;
  s.replicates = 2;
  s.tileSize = 8;
  s.tileSamples = {n0, n1};
  s.sum.assign(size_t(16 * 8 * 2) * ReferenceSums::kValues, 0.0);
  for (int y = 0; y < 8; ++y)
    for (int x = 0; x < 16; ++x)
      for (int r = 0; r < 2; ++r)
        for (int j = 0; j < ReferenceSums::kValues; ++j) {
          const int n = x < 8 ? n0 : n1;
          const double spread = x < 8 ? spread0 : spread1;
          s.sum[((size_t(y) * 16 + size_t(x)) * 2 + size_t(r)) * ReferenceSums::kValues + size_t(j)] =
              n * (1.0 + (r == 0 ? spread : -spread));
        }
  return s;
}

TEST(Reference, AdaptiveAllocationIsTheNeymanAllocationOfTheRoundsSamples) {
  // Doubling: budget 2 x 4 x 128 pixel-samples: 64 n0 + 64 n1 = 1024 with n1 = 4 n0 gives n0 3.2,
  // below its current 4; so n0 stays 4 and n1 takes the rest, 12, rounded to the power of two 16.
  EXPECT_EQ(nextReferenceAllocation(twoTileSums(0.01, 0.04, 4, 4), 1024, 2.0), (std::vector<int>{4, 16}));
  // The references' rounds grow by sqrt(2): 64 n1 = 724 - 256 gives n1 7.3, rounded to 8.
  EXPECT_EQ(nextReferenceAllocation(twoTileSums(0.01, 0.04, 4, 4), 1024), (std::vector<int>{4, 8}));
  // The cap: tile 1 stops at 8 and the rest of the budget goes to tile 0.
  EXPECT_EQ(nextReferenceAllocation(twoTileSums(0.01, 0.04, 4, 4), 8, 2.0), (std::vector<int>{8, 8}));
  // Equal errors at equal counts: both double. Equal errors, but tile 1 reached its error with 4x
  // the samples: its per-sample error is 4x, so it gets 2x tile 0's count: 64 n0 + 64 (2 n0) =
  // 2 (4 + 16) 64 gives n0 13.3 and n1 26.7, rounded to 16 and 32.
  EXPECT_EQ(nextReferenceAllocation(twoTileSums(0.02, 0.02, 4, 4), 1024, 2.0), (std::vector<int>{8, 8}));
  EXPECT_EQ(nextReferenceAllocation(twoTileSums(0.02, 0.02, 4, 16), 1024, 2.0), (std::vector<int>{16, 32}));
  // A round smaller than any doubling (1.25 x 512 = 640: the ideal 5 per pixel rounds down to 4)
  // doubles the tiles that save the most per sample while the budget lasts, and at least one.
  EXPECT_EQ(nextReferenceAllocation(twoTileSums(0.02, 0.02, 4, 4), 1024, 1.25), (std::vector<int>{8, 4}));
  EXPECT_EQ(nextReferenceAllocation(twoTileSums(0.02, 0.021, 4, 4), 1024, 1.25), (std::vector<int>{4, 8}));
  // No error left where samples may go: nothing to do (the caller reports the cap).
  EXPECT_EQ(nextReferenceAllocation(twoTileSums(0.0, 0.04, 4, 8), 8), (std::vector<int>{4, 8}));
  EXPECT_EQ(twoTileSums(0, 0, 4, 16).meanSpp(), 2 * 10.0);
}

// Adaptive rounds on cornell_static (a lit box: bright walls, a dark ceiling corner) keep the
// replicate variance honest (the bias of allocating from the samples already taken is invisible at
// this tolerance) and, at about the same samples, lower the error below a uniform allocation's.
TEST(Reference, AdaptiveAllocationLowersTheErrorAndStaysHonest) {
  const Scene scene = test::shippedScene("cornell_static");
  RayCounts counts;
  RenderSettings goldSettings = referenceSettings("sobol", 1024);
  goldSettings.referenceTile = 0;
  SequenceRenderer goldRenderer(withIndependentSeed(scene), goldSettings);
  ReferenceSums goldSums;
  goldRenderer.extendReference(0, goldSums, 128, counts);
  const LayerSet gold = referenceLayersFromSums(goldSums);
  SequenceRenderer r(scene, referenceSettings("sobol", 64));
  ReferenceSums adaptive;
  r.extendReference(0, adaptive, 2, counts);
  while (adaptive.meanSpp() < 64) r.extendReference(0, adaptive, nextReferenceAllocation(adaptive, 32), counts);
  EXPECT_LT(adaptive.meanSpp(), 100);
  EXPECT_LT(adaptive.minPerReplicate(), adaptive.maxPerReplicate());
  ReferenceSums uniform;
  r.extendReference(0, uniform, int(std::ceil(adaptive.meanSpp() / r.referenceReplicates())), counts);
  const double predicted = estimatedReferenceRelMse(adaptive);
  const double measured = trueRelMse(referenceLayersFromSums(adaptive), gold);
  EXPECT_GT(measured / predicted, 0.7) << "predicted " << predicted << " measured " << measured;
  EXPECT_LT(measured / predicted, 1.4) << "predicted " << predicted << " measured " << measured;
  EXPECT_LT(predicted, estimatedReferenceRelMse(uniform));
}

TEST(Reference, LayersHoldReplicateMeansVarianceAndHalf) {
  const Scene scene = test::shippedScene("cornell_static");
  RenderSettings s = referenceSettings("sobol", 16);
  s.referenceReplicates = 8;  // any even count; the arithmetic below is written out for 8
  SequenceRenderer r(scene, s);
  ReferenceSums sums;
  RayCounts counts;
  r.extendReference(0, sums, 2, counts);
  ASSERT_EQ(sums.replicates, 8);
  const LayerSet layers = referenceLayersFromSums(sums);
  const size_t pixel = 9 * 32 + 16;
  double means[8], total = 0, half = 0;
  for (int k = 0; k < 8; ++k) {
    means[k] = sums.sum[(pixel * 8 + size_t(k)) * ReferenceSums::kValues + 1] / 2.0;  // colour G
    total += means[k];
    if (k < 4) half += means[k];
  }
  const double mean = total / 8;
  double ss = 0;
  for (double m : means) ss += (m - mean) * (m - mean);
  EXPECT_FLOAT_EQ(layers.get("color").plane(1)[pixel], float(mean));
  EXPECT_FLOAT_EQ(layers.get("colorVar").plane(1)[pixel], float(ss / (8 * 7)));
  EXPECT_FLOAT_EQ(layers.get("colorHalf").plane(1)[pixel], float(half / 4));
  EXPECT_FALSE(samePixels(layers.get("colorHalf"), layers.get("color")));
}

TEST(Reference, CappedReferencesSayItAndSequenceJsonRecordsIt) {
  const auto cache = test::freshDir("reference_capped");
  RenderSettings s = referenceSettings("sobol", 16);
  s.referenceMinSpp = 8;
  s.referenceRelError = 1e-5;  // unreachable at 16 spp
  std::vector<std::string> lines;
  const auto dir =
      renderSequence(test::shippedScene("cornell_static"), s, cache, [&](const std::string& l) { lines.push_back(l); });
  bool warned = false;
  for (const std::string& l : lines)
    warned |=
        l.find("WARNING: reference 0 stopped at its cap of 16 spp") != std::string::npos &&
        l.find("above its target 1e-10 (a relMSE: a relative error of 1e-05;") != std::string::npos;
  EXPECT_TRUE(warned) << (lines.empty() ? "" : lines.back());
  const SequenceInfo info = Sequence::open(dir).info();
  ASSERT_EQ(info.referenceCapped.size(), 1u);
  EXPECT_TRUE(info.referenceCapped[0]);
  EXPECT_GT(info.referenceEstimatedRelMse[0], 1e-10);
  EXPECT_EQ(info.referenceSpp[0], 16);
  // A reachable target stops early and is not capped.
  s.referenceRelError = 10;
  s.referenceSpp = 64;
  const SequenceInfo loose =
      Sequence::open(renderSequence(test::shippedScene("cornell_static"), s, cache, nullptr)).info();
  EXPECT_FALSE(loose.referenceCapped[0]);
  EXPECT_EQ(loose.referenceSpp[0], 8);
}

// `arena refine`: a loosely rendered sequence refined to a strict target holds the same bits as
// one rendered with the strict target from the start.
// A round of the adaptive schedule is carried out tile by tile, in order of the error each tile
// saves per sample, and a reference stops at the first tile after which it meets its target. So
// it holds the samples of the same rounds as a schedule that could stop only between rounds (as
// until 2026-11-27), its last round part way, and no more than that schedule's.
TEST(Reference, AReferenceStopsAtTheTileThatMeetsItsTarget) {
  const Scene scene = test::shippedScene("cornell_static");
  RenderSettings s = referenceSettings("sobol", 1024);
  s.referenceMinSpp = 16;
  const double target = 3e-4;
  SequenceRenderer r(scene, s);
  ReferenceSums stopped;
  const ReferenceResult result = r.continueReference(0, stopped, target, 1024);
  EXPECT_LE(result.estimatedRelMse, target);
  EXPECT_EQ(result.estimatedRelMse, estimatedReferenceRelMse(stopped));
  // The same rounds, each carried out whole.
  ReferenceSums whole;
  RayCounts counts;
  r.extendReference(0, whole, (16 + r.referenceReplicates() - 1) / r.referenceReplicates(), counts);  // the 16-spp pilot
  std::vector<int> lastRoundStart;
  while (estimatedReferenceRelMse(whole) > target) {
    lastRoundStart = whole.tileSamples;
    r.extendReference(0, whole, nextReferenceAllocation(whole, 128), counts);
  }
  ASSERT_FALSE(lastRoundStart.empty()) << "the pilot met the target: no round to stop in";
  ASSERT_TRUE(stopped.roundPending()) << "stopped at the last tile of its round: nothing to compare";
  EXPECT_EQ(stopped.roundTarget, whole.tileSamples) << "the stopped round is the whole schedule's last";
  for (size_t i = 0; i < whole.tileSamples.size(); ++i) {
    EXPECT_GE(stopped.tileSamples[i], lastRoundStart[i]) << "tile " << i;
    EXPECT_LE(stopped.tileSamples[i], whole.tileSamples[i]) << "tile " << i;
  }
  EXPECT_LT(stopped.meanSpp(), whole.meanSpp());
  // The tiles the round reached hold the same samples as the whole round's.
  for (int y = 0; y < whole.height; ++y)
    for (int x = 0; x < whole.width; ++x) {
      const int tile = whole.tileOf(x, y);
      if (stopped.tileSamples[size_t(tile)] != whole.tileSamples[size_t(tile)]) continue;
      const size_t at = (size_t(y) * size_t(whole.width) + size_t(x)) * size_t(whole.replicates) * ReferenceSums::kValues;
      for (size_t k = 0; k < size_t(whole.replicates) * ReferenceSums::kValues; ++k)
        ASSERT_EQ(stopped.sum[at + k], whole.sum[at + k]) << "pixel " << x << "," << y;
    }
}

// A reference that stopped part way through a round keeps the round in its sums file, and refining
// it finishes that round first: the same bits as rendering the stricter target in one go.
TEST(Reference, RefiningGivesTheSameBitsAsRenderingTheTargetAtOnce) {
  const auto cache = test::freshDir("reference_refine");
  const Scene scene = test::shippedScene("cornell_static");
  RenderSettings loose = referenceSettings("sobol", 1024);
  loose.referenceReplicates = 8;  // the targets below stop the loose reference part way through a round at 8
  loose.referenceMinSpp = 16;
  loose.referenceRelError = 0.04;  // relMSE 1.6e-3: a round or two past the 16-spp pilot
  RenderSettings strict = loose;
  strict.referenceRelError = 0.02;  // relMSE 4e-4: a few adaptive rounds
  const auto looseDir = renderSequence(scene, loose, cache, nullptr);
  const SequenceInfo first = Sequence::open(looseDir).info();
  ASSERT_GT(first.referenceSpp[0], 16);
  ASSERT_TRUE(readReferenceSums(referenceSumsPath(looseDir, 0), first.hash, 0).roundPending())
      << "the loose reference should have stopped part way through a round";
  refineSequence(scene, loose, cache, strict.referenceRelError * strict.referenceRelError, 1024, nullptr);
  ASSERT_EQ(Sequence::open(looseDir).info().referenceSpp.size(), 1u);
  const auto strictDir = renderSequence(scene, strict, cache, nullptr);
  const SequenceInfo a = Sequence::open(looseDir).info(), b = Sequence::open(strictDir).info();
  EXPECT_GT(a.referenceSpp[0], first.referenceSpp[0]);
  EXPECT_EQ(a.referenceSpp, b.referenceSpp);
  EXPECT_EQ(a.referenceEstimatedRelMse, b.referenceEstimatedRelMse);
  EXPECT_EQ(a.referenceCapped, b.referenceCapped);
  const ReferenceSums refined = readReferenceSums(referenceSumsPath(looseDir, 0), a.hash, 0);
  EXPECT_LT(refined.minPerReplicate(), refined.maxPerReplicate()) << "the refinement should be adaptive";
  EXPECT_FALSE(a.referenceCapped[0]);
  EXPECT_EQ(refined.tileSamples, readReferenceSums(referenceSumsPath(strictDir, 0), b.hash, 0).tileSamples);
  const LayerSet ra = Sequence::open(looseDir).reference(0), rb = Sequence::open(strictDir).reference(0);
  for (const auto& [name, img] : rb.all()) EXPECT_TRUE(samePixels(ra.get(name), img)) << name;
  // The sums file names what is wrong with a foreign one.
  try {
    readReferenceSums(referenceSumsPath(looseDir, 0), b.hash, 0);
    FAIL() << "accepted sums of another sequence";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("reference_000.sums"), std::string::npos) << e.what();
  }
  // A pending round that does not fit the tiles (one count, or below a tile's samples) is refused,
  // naming the file and the field.
  const std::filesystem::path sumsFile = referenceSumsPath(looseDir, 0);
  const std::string bytes = readText(sumsFile);
  uint32_t size = 0;
  std::memcpy(&size, bytes.data() + 8, sizeof size);
  const nlohmann::json header = nlohmann::json::parse(bytes.substr(12, size));
  const size_t tiles = header["tileSamples"].size();
  for (const std::vector<int>& bad : {std::vector<int>{1 << 20}, std::vector<int>(tiles, 0)}) {
    nlohmann::json h = header;
    h["roundTarget"] = bad;
    const std::string text = h.dump();
    const uint32_t n = uint32_t(text.size());
    writeTextAtomically(sumsFile, bytes.substr(0, 8) + std::string(reinterpret_cast<const char*>(&n), sizeof n) + text +
                            bytes.substr(12 + size));
    try {
      readReferenceSums(sumsFile, a.hash, 0);
      FAIL() << "accepted roundTarget " << h["roundTarget"].dump().substr(0, 40);
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("reference_000.sums"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("'roundTarget'"), std::string::npos) << e.what();
    }
  }
}

std::string fileBytes(const std::filesystem::path& p) {
  return readText(p);
}

// `arena render --shard i/n`: three shards and the merging render give the same files as one
// unsharded render, with a fixed sample count (replicate units) and with a target (reference
// units).
TEST(Reference, ThreeShardsMergeToTheUnshardedFilesBitForBit) {
  const Scene scene = test::shippedScene("camera_pan_occluder");
  for (const double relError : {0.0, 0.05}) {
    RenderSettings s = test::tinySettings(24, 14, 4, 32);
    s.referenceMinSpp = 16;
    s.referenceRelError = relError;
    const auto sharded = test::freshDir("reference_shards"), whole = test::freshDir("reference_whole");
    for (int i = 0; i < 3; ++i) {
      const auto dir = renderSequence(scene, s, sharded, nullptr, Shard{i, 3});
      EXPECT_FALSE(std::filesystem::exists(dir / "sequence.json")) << "a shard wrote sequence.json";
    }
    if (relError == 0) {  // a slice per replicate, the last one's too
      const int last = SequenceRenderer(scene, s).referenceReplicates() - 1;
      EXPECT_TRUE(std::filesystem::exists(replicateSumsPath(sequenceDir(scene, s, sharded), 0, last)));
    }
    std::vector<std::string> lines;
    const auto a = renderSequence(scene, s, sharded, [&](const std::string& l) { lines.push_back(l); });
    for (const std::string& l : lines) EXPECT_EQ(l.find("frame"), std::string::npos) << "the merge re-rendered: " << l;
    const auto b = renderSequence(scene, s, whole, nullptr);
    std::vector<std::string> names;
    for (const auto& e : std::filesystem::directory_iterator(b)) names.push_back(e.path().filename().string());
    std::vector<std::string> namesA;
    for (const auto& e : std::filesystem::directory_iterator(a)) namesA.push_back(e.path().filename().string());
    std::sort(names.begin(), names.end());
    std::sort(namesA.begin(), namesA.end());
    EXPECT_EQ(names, namesA);
    EXPECT_GT(names.size(), 8u);
    for (const std::string& n : names) {
      if (n == "sequence.json") {  // the measured path rates are timing metadata, not pixels
        auto withoutRates = [](const std::filesystem::path& file) {
          nlohmann::json j = nlohmann::json::parse(fileBytes(file));
          j.erase("inputPathsPerSecond");
          j.erase("lowresPathsPerSecond");
          return j;
        };
        EXPECT_EQ(withoutRates(a / n), withoutRates(b / n)) << n << " rel error " << relError;
        continue;
      }
      EXPECT_EQ(fileBytes(a / n), fileBytes(b / n)) << n << " rel error " << relError;
    }
  }
  EXPECT_THROW(
      renderSequence(scene, test::tinySettings(24, 14, 4, 32), test::freshDir("bad_shard"), nullptr, Shard{3, 3}),
      Error);
}

// References do not depend on the 1-spp input's seed: every seed's sequence links one set of
// reference files (in the seedless settings' directory) instead of rendering its own, and a
// refinement through any of them reaches all.
TEST(Reference, InputSeedsShareOneReference) {
  const auto cache = test::freshDir("reference_seeds");
  const Scene scene = test::shippedScene("moving_object");
  const RenderSettings base = test::tinySettings(24, 14, 3, 16);
  RenderSettings seed7 = base, seed8 = base;
  seed7.inputSeed = 7;
  seed8.inputSeed = 8;
  auto renderedReferences = [&](const RenderSettings& s, std::filesystem::path& dir) {
    int count = 0;
    dir = renderSequence(scene, s, cache,
                         [&](const std::string& l) { count += l.find("] reference ") != std::string::npos; });
    return count;
  };
  std::filesystem::path dir7, dirBase, dir8;
  const int first = renderedReferences(seed7, dir7);
  EXPECT_GT(first, 0);
  EXPECT_EQ(renderedReferences(base, dirBase), 0) << "the seedless sequence rendered its references again";
  EXPECT_EQ(renderedReferences(seed8, dir8), 0) << "a second input seed rendered its references again";
  EXPECT_EQ(referenceDir(scene, seed8, cache), dirBase);
  EXPECT_NE(dir7, dirBase);
  const SequenceInfo info = Sequence::open(dir8).info();
  EXPECT_EQ(int(info.referenceSpp.size()), first);
  for (int r = 0; r < first; ++r) {
    EXPECT_EQ(fileBytes(Sequence::referencePath(dir7, r)), fileBytes(Sequence::referencePath(dirBase, r)));
    EXPECT_EQ(fileBytes(Sequence::referencePath(dir8, r)), fileBytes(Sequence::referencePath(dirBase, r)));
  }
  EXPECT_EQ(Sequence::open(dir8).info().referenceSpp, Sequence::open(dirBase).info().referenceSpp);
  // The inputs do differ.
  EXPECT_FALSE(samePixels(Sequence::open(dir7).frame(1).get("color"), Sequence::open(dir8).frame(1).get("color")));
  // Refined through seed 8: the home's files change and every seed sees them after its next render.
  refineSequence(scene, seed8, cache, 1e-7, 64, nullptr);
  EXPECT_EQ(Sequence::open(dir8).info().referenceSpp[0], 64);
  EXPECT_EQ(fileBytes(Sequence::referencePath(dir8, 0)), fileBytes(Sequence::referencePath(dirBase, 0)));
  EXPECT_EQ(renderedReferences(seed7, dir7), 0);
  EXPECT_EQ(Sequence::open(dir7).info().referenceSpp[0], 64);
  EXPECT_EQ(fileBytes(Sequence::referencePath(dir7, 0)), fileBytes(Sequence::referencePath(dirBase, 0)));
}

// The study's reference-quality verdict: floor over the best real denoiser's corrected relMSE
// (baselines excluded, frames before the warm-up ignored), with the reason when the goal is missed.
TEST(Reference, QualityVerdictNamesTheRatioAndWhy) {
  auto pair = [](const std::string& scene, const std::string& denoiser, double corrected) {
    return nlohmann::json{{"scene", scene},
                          {"denoiser", denoiser},
                          {"label", denoiser},
                          {"status", "ok"},
                          {"summary", {{"relMseCorrected", {{"mean", corrected}}}}}};
  };
  nlohmann::json results = {
      {"scenes",
       {{"capped", {{"referenceRelMse", {1.0, 4e-4, 4e-4}}, {"referenceCapped", {true, false}}}},
        {"loose",
         {{"referenceRelMse", {1.0, 1e-4, 1e-4}},
          {"referenceCapped", {false}},
          {"width", 64},
          {"height", 36},
          {"frames", 3}}},
        {"fine", {{"referenceRelMse", {1.0, 1e-5, 3e-5}}, {"referenceCapped", {false}}}}}},
      {"pairs",
       {pair("capped", "svgf", 2e-3), pair("capped", "passthrough", 1e-9),
        pair("loose", "asvgf", 2e-4), pair("fine", "svgf", 4e-4), pair("fine", "temporal", 1e-9)}},
      // The study's settings: its low-res buffer is part of the sequences' hash, so the printed
      // command must carry it or it finds nothing to refine.
      {"settings",
       {{"render", RenderSettings::fromPreset("quick").pixelSettings(
                       test::shippedScene("cornell_static"))}}}};
  results["settings"]["render"]["lowresFactor"] = 8;
  results["settings"]["render"]["lowresSpp"] = 16;
  addReferenceQuality(results, 1, {}, "/tmp/my cache");
  const nlohmann::json& capped = results["scenes"]["capped"]["referenceQuality"];
  EXPECT_NEAR(capped["ratio"].get<double>(), 0.2, 1e-12);  // 4e-4 / 2e-3: the passthrough is no denoiser
  EXPECT_FALSE(capped["meets"].get<bool>());
  EXPECT_NE(capped["verdict"].get<std::string>().find("NOT MET"), std::string::npos);
  EXPECT_NE(capped["verdict"].get<std::string>().find("1 of 2 references stopped at their sample cap"),
            std::string::npos)
      << capped["verdict"];
  const std::string loose = results["scenes"]["loose"]["referenceQuality"]["verdict"];
  EXPECT_NE(loose.find("= 0.5 > 0.1: NOT MET"), std::string::npos) << loose;
  EXPECT_NE(loose.find("met their target, which is too loose"), std::string::npos) << loose;
  // The command finds the run's sequences: the size and length they ran at, its cache.
  EXPECT_NE(loose.find("`arena refine loose --resolution 64x36 --frames 3 --lowres-factor 8 "
                       "--cache '/tmp/my cache' "
                       "--target 2e-05`"),
            std::string::npos)
      << loose;
  // A cache whose path holds a quote, and a run's --max-bounces: the pasted command still names
  // the run's sequences.
  results["scenes"]["loose"]["maxBounces"] = 3;
  addReferenceQuality(results, 1, {}, "/tmp/Ann's cache");
  const std::string quoted = results["scenes"]["loose"]["referenceQuality"]["verdict"];
  EXPECT_NE(quoted.find("`arena refine loose --resolution 64x36 --frames 3 --lowres-factor 8 "
                        "--max-bounces 3 --cache '/tmp/Ann'\\''s cache' --target 2e-05`"),
            std::string::npos)
      << quoted;
  results["scenes"]["loose"].erase("maxBounces");
  const nlohmann::json& fine = results["scenes"]["fine"]["referenceQuality"];
  EXPECT_NEAR(fine["floor"].get<double>(), 2e-5, 1e-15);
  EXPECT_TRUE(fine["meets"].get<bool>());
  // Just past the goal: as many digits as tell the ratio from it ("0.1 > 0.1" read as a
  // contradiction).
  results["scenes"]["edge"] = {{"referenceRelMse", {1.0, 1.018e-5, 1.018e-5}},
                               {"referenceCapped", {false}}};
  results["pairs"].push_back(pair("edge", "svgf", 1e-4));
  addReferenceQuality(results, 1);
  const std::string edge = results["scenes"]["edge"]["referenceQuality"]["verdict"];
  EXPECT_NE(edge.find("= 0.102 > 0.1: NOT MET, the reference's noise must fall 1.02x"),
            std::string::npos)
      << edge;
  results["scenes"].erase("edge");
  EXPECT_EQ(referenceQualityLines(results["scenes"]).size(), 3u);
  // A capture's references were rendered elsewhere: no `arena refine` (it finds no such scene).
  results["scenes"]["loose"]["source"] = "capture";
  addReferenceQuality(results, 1);
  const std::string capture = results["scenes"]["loose"]["referenceQuality"]["verdict"];
  EXPECT_EQ(capture.find("arena refine loose"), std::string::npos) << capture;
  EXPECT_NE(capture.find("a capture's references come from the renderer that made them"),
            std::string::npos)
      << capture;
  // A capture no longer than the warm-up: the floor is unmeasured for that reason, not for want
  // of colorVar (which these references have).
  addReferenceQuality(results, 3);
  const std::string short_ = results["scenes"]["loose"]["referenceQuality"]["verdict"];
  EXPECT_NE(
      short_.find("reference quality unknown (no frame after the warm-up of 3 to measure it on)"),
      std::string::npos)
      << short_;
}

// Between a scene's events its references differ (a light switched off has its own): the ratio
// per segment, and a segment above the goal said beside a met verdict, which stays the scene's.
TEST(Reference, QualityVerdictNamesASegmentAboveTheGoal) {
  nlohmann::json frames = nlohmann::json::array();
  for (int t = 0; t < 8; ++t)
    frames.push_back({{"frame", t}, {"relMseCorrected", t < 4 ? 1e-2 : 1e-3}});
  nlohmann::json results = {
      {"scenes",
       {{"switch",
         {{"referenceRelMse", {1.0, 1e-4, 1e-4, 1e-4, 2e-4, 2e-4, 2e-4, 2e-4}},
          {"referenceCapped", {false, false}},
          {"events", {{{"frame", 4}, {"kind", "light_off"}, {"what", "lamp"}}}}}}}},
      {"pairs",
       {{{"scene", "switch"},
         {"denoiser", "svgf"},
         {"label", "svgf"},
         {"status", "ok"},
         {"frames", frames},
         {"summary", {{"relMseCorrected", {{"mean", (3 * 1e-2 + 4 * 1e-3) / 7}}}}}}}}};
  addReferenceQuality(results, 1);
  const nlohmann::json& q = results["scenes"]["switch"]["referenceQuality"];
  // The scene: (3e-4 + 8e-4) / 7 over 0.034 / 7 = 0.032, met; frames 4-7: 2e-4 / 1e-3 = 0.2.
  EXPECT_TRUE(q["meets"].get<bool>());
  ASSERT_EQ(q["segments"].size(), 2u);
  EXPECT_EQ(q["segments"][0]["from"], 1);
  EXPECT_EQ(q["segments"][0]["to"], 3);
  EXPECT_NEAR(q["segments"][0]["ratio"].get<double>(), 1e-2, 1e-12);
  EXPECT_EQ(q["segments"][1]["from"], 4);
  EXPECT_NEAR(q["segments"][1]["ratio"].get<double>(), 0.2, 1e-12);
  EXPECT_NE(q["verdict"].get<std::string>().find(
                ": met for the scene's mean, not between its events (frames 4-7 0.2 > 0.1"),
            std::string::npos)
      << q["verdict"];
  // Marked for the readers, which say it as they say a missed goal.
  EXPECT_FALSE(q["segmentsMeet"].get<bool>());
  EXPECT_EQ(segmentQualityLines(results["scenes"]), std::vector<std::string>{q["verdict"]});
  // An event beyond the frames (a sequence shorter than the scene's script) bounds nothing.
  results["scenes"]["switch"]["events"].push_back(
      {{"frame", 30}, {"kind", "light_on"}, {"what", "lamp"}});
  addReferenceQuality(results, 1);
  EXPECT_EQ(results["scenes"]["switch"]["referenceQuality"]["segments"].size(), 2u);
  // Before the first event no event figure is measured: a segment there above the goal is kept,
  // not said.
  results["scenes"]["switch"]["referenceRelMse"] = {1.0, 2e-3, 2e-3, 2e-3, 1e-5, 1e-5, 1e-5, 1e-5};
  for (int t = 4; t < 8; ++t) results["pairs"][0]["frames"][size_t(t)]["relMseCorrected"] = 0.1;
  results["pairs"][0]["summary"]["relMseCorrected"]["mean"] = (3 * 1e-2 + 4 * 0.1) / 7;
  addReferenceQuality(results, 1);
  const nlohmann::json& before = results["scenes"]["switch"]["referenceQuality"];
  EXPECT_TRUE(before["meets"].get<bool>()) << before["verdict"];
  EXPECT_NEAR(before["segments"][0]["ratio"].get<double>(), 0.2, 1e-12);
  EXPECT_EQ(before["verdict"].get<std::string>().find("between its events"), std::string::npos)
      << before["verdict"];
  EXPECT_TRUE(before["segmentsMeet"].get<bool>());
  EXPECT_TRUE(segmentQualityLines(results["scenes"]).empty());
  // Without events there is one segment, the scene's: nothing more is said.
  results["scenes"]["switch"].erase("events");
  addReferenceQuality(results, 1);
  EXPECT_FALSE(results["scenes"]["switch"]["referenceQuality"].contains("segments"));
  EXPECT_EQ(results["scenes"]["switch"]["referenceQuality"]["verdict"].get<std::string>().find(
                "between its events"),
            std::string::npos);
}

// The options that find a run's sequences again: what differs from the preset, nothing more.
TEST(Reference, RenderOptionsOfARunReproduceItsSettings) {
  const Scene scene = test::shippedScene("cornell_static");
  EXPECT_EQ(renderOptionsOf(RenderSettings::fromPreset("quick").pixelSettings(scene)), "");
  EXPECT_EQ(renderOptionsOf(RenderSettings::fromPreset("paper").pixelSettings(scene)), " --preset paper");
  RenderSettings s = RenderSettings::fromPreset("quick");
  s.referenceSpp = 1024;
  s.referenceRelError = 0.005;
  s.referenceSampler = "independent";
  s.referenceTile = 0;
  s.inputSeed = 3;
  s.lowresFactor = 4;
  s.lowresSpp = 32;
  EXPECT_EQ(renderOptionsOf(s.pixelSettings(scene)),
            " --ref-spp 1024 --ref-rel-error 0.0050000000000000001 --ref-sampler independent --ref-tile 0 "
            "--input-seed 3 --lowres-factor 4 --lowres-spp 32");
  EXPECT_EQ(renderOptionsOf(nlohmann::json{{"preset", "draft"}}), "");  // unknown preset: no options
  EXPECT_EQ(renderOptionsOf(nlohmann::json()), "");
}

// The study's refinement plan: targets with the margin, predicted paths from the rounds a
// reference needs (capped, warm-up-only references left out), each scene within its own budget in
// units of its frames at the references' sample cap, cheapest first.
TEST(Reference, RefinementPlanRefinesEachSceneWithinItsOwnBudget) {
  auto quality = [](bool meets, double best) {
    return nlohmann::json{{"referenceQuality", {{"meets", meets}, {"bestCorrectedRelMse", best}}}};
  };
  const nlohmann::json results = {
      {"scenes", {{"dear", quality(false, 1e-3)}, {"cheap", quality(false, 1e-3)}, {"fine", quality(true, 1e-3)}}}};
  auto sequence = [](std::vector<int> ofFrame, std::vector<int> spp, std::vector<double> est, int cap) {
    SequenceInfo info;
    info.width = info.height = 10;
    info.referenceOfFrame = std::move(ofFrame);
    info.referenceSpp = std::move(spp);
    info.referenceEstimatedRelMse = std::move(est);
    if (cap > 0) info.settings = {{"referenceSpp", cap}};
    return info;
  };
  std::map<std::string, SequenceInfo> sequences = {
      // 1e-4 -> 9e-5 at relMSE ~ 1/spp: 100 -> 111.1 spp on 100 pixels.
      {"cheap", sequence({0, 0, 0, 0}, {100}, {1e-4}, 400)},
      // Reference 0 serves the warm-up frame only; reference 1 needs 11.1x, capped at 1000.
      // No cap in its settings: the unit falls back to the samples the references hold.
      {"dear", sequence({0, 1, 1, 1}, {100, 100}, {1e-2, 1e-3}, 0)},
      {"fine", sequence({0, 0, 0, 0}, {100}, {1e-5}, 400)}};
  const std::vector<ReferenceRefinement> plans = planReferenceRefinement(results, sequences, 1, 1000, 1.5);
  ASSERT_EQ(plans.size(), 2u);
  EXPECT_EQ(plans[0].scene, "cheap");
  EXPECT_DOUBLE_EQ(plans[0].targetRelMse, kRefineMargin * kReferenceQualityGoal * 1e-3);
  const double cheapPaths = 100.0 * (100 * (1e-4 / (kRefineMargin * kReferenceQualityGoal * 1e-3)) - 100);
  EXPECT_DOUBLE_EQ(plans[0].predictedPaths, cheapPaths);
  EXPECT_DOUBLE_EQ(plans[0].budgetNeeded, cheapPaths / 160000);  // 4 frames at the cap: 400 spp x 100 pixels each
  EXPECT_TRUE(plans[0].withinBudget);
  EXPECT_EQ(plans[1].scene, "dear");
  EXPECT_DOUBLE_EQ(plans[1].predictedPaths, 100.0 * 900);
  EXPECT_DOUBLE_EQ(plans[1].budgetNeeded, 90000.0 / 40000);  // 4 frames whose references hold 100 spp x 100 pixels
  EXPECT_FALSE(plans[1].withinBudget);
  const std::string note = refinementNote(plans[1], 1.5);
  EXPECT_NE(note.find("not refined by the study"), std::string::npos) << note;
  EXPECT_NE(note.find("`arena study --refine-budget 2.3`"), std::string::npos) << note;
  EXPECT_NE(refinementNote(plans[0], 1.5).find("refined its references toward 9e-05"), std::string::npos);
  // The cache's history does not move a scene's decision: once "cheap" holds more samples (a rerun
  // after its refinement, when it may still miss), "dear" is planned exactly as before.
  sequences["cheap"].referenceSpp = {200};
  for (const ReferenceRefinement& p : planReferenceRefinement(results, sequences, 1, 1000, 1.5))
    if (p.scene == "dear") {
      EXPECT_DOUBLE_EQ(p.budgetNeeded, plans[1].budgetNeeded);
      EXPECT_FALSE(p.withinBudget);
    }
  // Counted at a given cap (the study's budget, at the preset's cap, for references rendered under
  // a lower one), which overrides the cap in a sequence's settings: "dear" costs 90000 paths of 4
  // frames x 100 pixels x 1000 spp, "cheap" (rendered under 400) its paths over 4 x 100 x 1000.
  for (const ReferenceRefinement& p :
       planReferenceRefinement(results, sequences, 1, 1000, 1.5, 1000))
    if (p.scene == "dear") {
      EXPECT_DOUBLE_EQ(p.budgetNeeded, 90000.0 / 400000);
      EXPECT_TRUE(p.withinBudget);
    } else {
      EXPECT_DOUBLE_EQ(p.budgetNeeded, p.predictedPaths / 400000);  // not its settings' 400 spp
    }
  // A budget of 0 refines nothing; a scene without a sequence is not planned.
  for (const ReferenceRefinement& p : planReferenceRefinement(results, sequences, 1, 1000, 0)) EXPECT_FALSE(p.withinBudget);
  EXPECT_TRUE(planReferenceRefinement(results, {}, 1, 1000, 1).empty());
}

// A scene whose floor is more than kRefineStageTrigger x its best corrected relMSE (that best a
// small difference of noisy numbers) is refined in a first round only to where its floor is the
// best, to be measured again; a scene whose floor is less (here 1.5x), or one that stopped short
// before, goes to the target at once.
TEST(Reference, RefinementStopsShortWhileTheFloorOutweighsTheBest) {
  auto quality = [](double floor, double best) {
    return nlohmann::json{
        {"referenceQuality", {{"meets", false}, {"floor", floor}, {"bestCorrectedRelMse", best}}}};
  };
  const nlohmann::json results = {
      {"scenes", {{"noisy", quality(5e-2, 1e-2)}, {"clean", quality(1.5e-2, 1e-2)}}}};
  SequenceInfo info;
  info.width = info.height = 10;
  info.referenceOfFrame = {0, 0};
  info.referenceSpp = {128};
  info.referenceEstimatedRelMse = {5e-2};
  info.settings = {{"referenceSpp", 512}};
  SequenceInfo cleanInfo = info;
  cleanInfo.referenceEstimatedRelMse = {1.5e-2};
  const std::map<std::string, SequenceInfo> sequences = {{"noisy", info}, {"clean", cleanInfo}};
  const double target = kRefineMargin * kReferenceQualityGoal * 1e-2;
  for (const bool mayStopShort : {true, false})
    for (const ReferenceRefinement& p :
         planReferenceRefinement(results, sequences, 0, 1 << 20, 100, 0, mayStopShort)) {
      SCOPED_TRACE(p.scene + (mayStopShort ? " may stop short" : " to the target"));
      EXPECT_DOUBLE_EQ(p.targetRelMse, target);
      const double e = p.scene == "noisy" ? 5e-2 : 1.5e-2;
      EXPECT_DOUBLE_EQ(p.predictedPaths, 100.0 * (128 * (e / target) - 128));
      if (p.scene == "noisy" && mayStopShort) {
        EXPECT_DOUBLE_EQ(p.roundTargetRelMse, kRefineStageRatio * 1e-2);
        EXPECT_DOUBLE_EQ(p.roundPaths, 100.0 * (128 * (5e-2 / (kRefineStageRatio * 1e-2)) - 128));
        EXPECT_LT(p.roundPaths, p.predictedPaths);
        EXPECT_DOUBLE_EQ(p.roundBudgetNeeded, p.roundPaths / (2 * 100 * 512.0));
        const std::string note = refinementNote(p, 100);
        EXPECT_NE(note.find("toward 0.01 (predicted"), std::string::npos) << note;
        EXPECT_NE(note.find("to measure that best again"), std::string::npos) << note;
      } else {
        EXPECT_DOUBLE_EQ(p.roundTargetRelMse, target);
        EXPECT_DOUBLE_EQ(p.roundPaths, p.predictedPaths);
        EXPECT_DOUBLE_EQ(p.roundBudgetNeeded, p.budgetNeeded);
      }
    }
}

// End to end: a study whose references are far too noisy for its scene (16 spp) says so; with a
// refinement budget it refines them, runs again, and its verdict says what it did.
// The study run of the refinement tests: a scene (cornell_static) at 32x18, 10 frames, with
// `references` (16-spp references at no target), the cache and the runs in `dir`.
test::CommandResult tinyStudy(const std::filesystem::path& dir, const std::string& run, const std::string& budget,
                              const std::string& scene = "cornell_static",
                              const std::string& references = "--ref-spp 16 --ref-rel-error 0") {
  return test::runCommand(std::string(ARENA_BINARY) + " study --scenes " + scene +
                          " --resolution 32x18 --frames 10 --flip none " + references +
                          " --refine-max-spp 1024 --refine-budget " + budget + " --cache " + (dir / "cache").string() +
                          " --out " + (dir / run).string() + " --report " + (dir / (run + "_report")).string());
}

// hard_light with path-traced references (its file says "bidirectional"): at the tiny studies'
// 16 spp their floor, fireflies through the slit, outweighs the best. The `--scenes` argument that
// loads it.
std::string pathTracedHardLight(const std::filesystem::path& dir) {
  nlohmann::json scene = parseJsonFile(defaultScenesDir() + "/hard_light.json");
  scene["reference_estimator"] = "path";
  std::filesystem::create_directories(dir / "scenes");
  std::ofstream(dir / "scenes" / "hard_light.json") << scene.dump(1);
  return "hard_light --scenes-dir " + (dir / "scenes").string();
}

TEST(Reference, StudyRefinesReferencesThatMissTheGoal) {
  const std::filesystem::path dir = test::freshDir("study_refine");
  auto study = [&](const std::string& run, const std::string& budget) {
    const test::CommandResult r = tinyStudy(dir, run, budget);
    EXPECT_EQ(r.status, 0) << r.output;
    return std::make_pair(r.output, parseJsonFile((dir / run / "results.json").string())["scenes"]["cornell_static"]);
  };
  const auto [plainOutput, plain] = study("plain", "0");
  EXPECT_EQ(plainOutput.find("[refine]"), std::string::npos) << plainOutput;
  EXPECT_FALSE(plain["referenceQuality"]["meets"].get<bool>()) << plain["referenceQuality"];
  const auto [output, refined] = study("refined", "1000");
  EXPECT_NE(output.find("[refine] cornell_static: the study refined its references toward"), std::string::npos) << output;
  EXPECT_NE(output.find("[refine] cornell_static: its 10 pair(s) measured again against the refined references"), std::string::npos) << output;
  // Where its time went, stage by stage (core/stage_clock.hpp), after the summary.
  EXPECT_TRUE(std::regex_search(output, std::regex("\nTime by stage: ([a-z]+ [0-9m.]+s, )*other [0-9m.]+s\n"))) << output;
  const nlohmann::json& q = refined["referenceQuality"];
  EXPECT_LT(q["floor"].get<double>(), plain["referenceQuality"]["floor"].get<double>() / 4) << q;
  EXPECT_TRUE(q["meets"].get<bool>()) << q;
  EXPECT_NE(q["verdict"].get<std::string>().find("(the study refined its references toward"), std::string::npos) << q;
  // The run is committed once: the run directory's database holds the final measurements only.
  EXPECT_EQ(test::countRows(dir / "refined" / "results.db", "runs"), 1);
  EXPECT_EQ(test::countRows(dir / "plain" / "results.db", "runs"), 1);
}

// End to end, hard_light's 16-spp references (fireflies: a floor several times its best): the first
// round stops where the floor is the best, the pairs are screened again, and the second round goes
// to the target planned from the best measured against the cleaner references; the verdict notes
// both rounds.
TEST(Reference, StudyStopsShortWhereTheFloorOutweighsTheBest) {
  const std::filesystem::path dir = test::freshDir("study_refine_stop_short");
  const test::CommandResult r = tinyStudy(dir, "refined", "1000", pathTracedHardLight(dir));
  ASSERT_EQ(r.status, 0) << r.output;
  const std::string stop = "[refine] hard_light: the study refined its references toward ";
  const size_t first = r.output.find(stop);
  ASSERT_NE(first, std::string::npos) << r.output;
  const size_t firstEnd = r.output.find('\n', first);
  EXPECT_NE(
      r.output.substr(first, firstEnd - first).find("to measure that best again before the target"),
      std::string::npos)
      << r.output;
  const size_t second = r.output.find(stop, firstEnd);
  ASSERT_NE(second, std::string::npos) << r.output;
  EXPECT_EQ(
      r.output.substr(second, r.output.find('\n', second) - second).find("measure that best again"),
      std::string::npos)
      << "a scene stops short once\n"
      << r.output;
  const nlohmann::json q = parseJsonFile(
      (dir / "refined" / "results.json").string())["scenes"]["hard_light"]["referenceQuality"];
  const std::string verdict = q["verdict"].get<std::string>();
  EXPECT_NE(verdict.find("before the target; then the study refined its references toward"),
            std::string::npos)
      << verdict;
}

// A reference that cannot be refined (its sums are gone) is said so in the verdict; the study
// still finishes, with the pairs measured against the references it has.
TEST(Reference, StudySaysWhenItCannotRefine) {
  const std::filesystem::path dir = test::freshDir("study_refine_missing");
  ASSERT_EQ(tinyStudy(dir, "first", "0").status, 0);
  int removed = 0;
  for (const auto& e : std::filesystem::recursive_directory_iterator(dir / "cache"))
    if (e.path().extension() == ".sums") removed += int(std::filesystem::remove(e.path()));
  ASSERT_GT(removed, 0);
  const test::CommandResult r = tinyStudy(dir, "second", "1000");
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("[refine] cornell_static: the study could not refine it: "), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("measured again"), std::string::npos) << r.output;
  const nlohmann::json q =
      parseJsonFile((dir / "second" / "results.json").string())["scenes"]["cornell_static"]["referenceQuality"];
  EXPECT_FALSE(q["meets"].get<bool>()) << q;
  EXPECT_NE(q["verdict"].get<std::string>().find("(the study could not refine it: "), std::string::npos) << q;
}

// A refinement that fails part way (the second reference's sums are gone) leaves the first
// reference refined on disk: sequence.json records it, and the study measures the scene's pairs
// against it, as a run on that cache would, and says why it stopped.
TEST(Reference, AStudyWhoseRefinementFailsPartWayMeasuresWhatItRefined) {
  const std::filesystem::path dir = test::freshDir("study_refine_part_way");
  auto study = [&](const std::string& run, const std::string& budget) {
    return tinyStudy(dir, run, budget, "moving_object");
  };
  ASSERT_EQ(study("first", "0").status, 0);
  std::vector<std::filesystem::path> sums;
  for (const auto& e : std::filesystem::recursive_directory_iterator(dir / "cache"))
    if (e.path().extension() == ".sums") sums.push_back(e.path());
  std::sort(sums.begin(), sums.end());
  ASSERT_EQ(sums.size(), 2u) << "moving_object's 10 frames: the static start and frame 9";
  std::filesystem::remove(sums[1]);
  const test::CommandResult r = study("refined", "1000");
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("[refine] moving_object: the study could not refine it: "), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("measured again against the refined references"), std::string::npos) << r.output;
  const nlohmann::json refined = parseJsonFile((dir / "refined" / "results.json").string())["scenes"]["moving_object"];
  const nlohmann::json first = parseJsonFile((dir / "first" / "results.json").string())["scenes"]["moving_object"];
  EXPECT_GT(refined["referenceSpp"][0].get<int>(), first["referenceSpp"][0].get<int>()) << refined["referenceSpp"];
  EXPECT_EQ(refined["referenceSpp"][1], first["referenceSpp"][1]);
  // What the run measured is what the cache now holds: a plain run on it gives the same floor.
  ASSERT_EQ(study("after", "0").status, 0);
  const nlohmann::json after = parseJsonFile((dir / "after" / "results.json").string())["scenes"]["moving_object"];
  EXPECT_EQ(refined["referenceRelMse"], after["referenceRelMse"]);
  EXPECT_NE(refined["referenceQuality"]["verdict"].get<std::string>().find("(the study could not refine it: "),
            std::string::npos)
      << refined["referenceQuality"];
}

// The study refines every reference a summary reads: the summarised frames' (t >= the warm-up, 8)
// and the three before them, whose references the temporal metrics at frames 8 and 9 compare with
// (tRmae reads r_t - r_{t-1}, the stability metrics go three frames back); earlier ones stay.
TEST(Reference, StudyRefinesTheReferencesItsTemporalMetricsRead) {
  EXPECT_EQ(firstFrameSummariesRead(8), 8 - kMaxMetricHistory);
  EXPECT_EQ(firstFrameSummariesRead(2), 0);
  const std::filesystem::path dir = test::freshDir("study_refine_history");
  auto spp = [&](const std::string& run, const std::string& budget) {
    const test::CommandResult r = tinyStudy(dir, run, budget, "camera_pan_occluder");
    EXPECT_EQ(r.status, 0) << r.output;
    return parseJsonFile((dir / run / "results.json").string())["scenes"]["camera_pan_occluder"]["referenceSpp"];
  };
  const nlohmann::json plain = spp("plain", "0"), refined = spp("refined", "1000");
  ASSERT_EQ(plain.size(), 10u) << "the camera pans: a reference per frame";
  for (int t = 0; t < 10; ++t) {
    if (t < 5)
      EXPECT_EQ(refined[t], plain[t]) << "frame " << t;
    else
      EXPECT_GT(refined[t].get<int>(), plain[t].get<int>()) << "frame " << t;
  }
}

// With a refinement budget and no --ref-rel-error, the study renders its first references to
// kStudyFirstReferenceRelError under kStudyFirstReferenceSpp (the summarised frames' are refined to
// the goal); without a budget it keeps the preset's target and cap, and a given target or cap is
// kept (with a given target, the preset's cap). The refinement's budget is counted at the preset's
// cap either way: a scene the first render leaves within budget is refined.
TEST(Reference, StudyRendersItsFirstReferencesLooserWhenItWillRefineThem) {
  const std::filesystem::path dir = test::freshDir("study_first_references");
  auto render = [&](const std::string& run, const std::string& budget,
                    const std::string& references) {
    const test::CommandResult r = tinyStudy(dir, run, budget, "cornell_static", references);
    EXPECT_EQ(r.status, 0) << r.output;
    return parseJsonFile((dir / run / "results.json").string())["settings"]["render"];
  };
  const RenderSettings quick = RenderSettings::fromPreset("quick");
  const nlohmann::json refining = render("refining", "4", "--ref-spp 256");
  EXPECT_EQ(refining.value("referenceRelError", -1.0), kStudyFirstReferenceRelError);
  EXPECT_EQ(refining.value("referenceSpp", 0), 256) << "a given cap is kept, above the study's too";
  const nlohmann::json loose = render("loose", "4", "");
  EXPECT_EQ(loose.value("referenceRelError", -1.0), kStudyFirstReferenceRelError);
  EXPECT_EQ(loose.value("referenceSpp", 0), kStudyFirstReferenceSpp);
  EXPECT_LT(kStudyFirstReferenceSpp, quick.referenceSpp);
  const nlohmann::json plain = render("plain", "0", "");
  EXPECT_EQ(plain.value("referenceRelError", -1.0), quick.referenceRelError);
  EXPECT_EQ(plain.value("referenceSpp", 0), quick.referenceSpp);
  const nlohmann::json given = render("given", "4", "--ref-rel-error 0.005");
  EXPECT_EQ(given.value("referenceRelError", -1.0), 0.005);
  EXPECT_EQ(given.value("referenceSpp", 0), quick.referenceSpp)
      << "a given target keeps the preset's cap";
  // The budget a scene needs is counted at the preset's cap, not the first render's: hard_light
  // (path-traced) at 32x18 misses the goal, and the note's budget is its predicted paths over 10
  // frames x 32 x 18 pixels x 512 spp (rounded up to a tenth), where 128 spp would give four times
  // as much.
  const test::CommandResult tight = tinyStudy(dir, "tight", "0.0001", pathTracedHardLight(dir), "");
  ASSERT_EQ(tight.status, 0) << tight.output;
  std::smatch m;
  ASSERT_TRUE(
      std::regex_search(tight.output, m,
                        std::regex("about ([0-9.e+-]+) Mpaths more.*`arena study --refine-budget "
                                   "([0-9.]+)` covers it")))
      << tight.output;
  const double needed = std::stod(m[1]) * 1e6 / (10.0 * 32 * 18 * quick.referenceSpp);
  // (The note's paths have two significant digits: 5% either way.)
  EXPECT_GE(std::stod(m[2]), 0.95 * needed - 0.001) << tight.output;
  EXPECT_LE(std::stod(m[2]), 1.05 * needed + 0.1) << tight.output;
}

// For a scene whose references are bidirectional the bench's baseline stays the plain path tracer
// (independent sampler) and its Sobol rows and gold are the scene's estimator: hard_light's gain
// is the whole of what the study's references gain.
TEST(Reference, BenchReferenceMeasuresABidirectionalSceneAgainstThePathTracer) {
  const std::filesystem::path json = test::freshDir("bench_reference_bidirectional") / "bench.json";
  const test::CommandResult r = test::runCommand(
      std::string(ARENA_BINARY) + " bench reference --scenes hard_light --resolution 32x18 " +
      "--spp 64 --gold-factor 8 --repeats 2 --json " + json.string());
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("independent path relMSE"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("bidirectional sobol"), std::string::npos) << r.output;
  const nlohmann::json scene = parseJsonFile(json.string())["scenes"][0];
  EXPECT_EQ(scene["estimator"], "bidirectional");
  EXPECT_GT(scene["gain"].get<double>(), 2.0) << scene;
}

// `arena bench reference` end to end on a tiny frame: a line per scene ending in its gain, the JSON
// beside it; --max-bounces shortens every path (the gold's too): with direct light only (one bounce)
// a 2D-stratified integrand, on which Sobol must beat the independent sampler at equal samples.
TEST(Reference, BenchReferencePrintsGainsAndShortensPaths) {
  const std::filesystem::path json = test::freshDir("bench_reference") / "bench.json";
  const test::CommandResult r =
      test::runCommand(std::string(ARENA_BINARY) + " bench reference --scenes cornell_static --resolution 24x14 " +
                       "--spp 32 --gold-factor 8 --max-bounces 1 --json " + json.string());
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_TRUE(std::regex_search(r.output, std::regex("cornell_static .* gain [0-9.]+x \\[95% CI [0-9.]+, [0-9.]+\\]\\n")))
      << r.output;
  const nlohmann::json out = parseJsonFile(json.string());
  EXPECT_EQ(out["maxBounces"], 1);
  const nlohmann::json& scene = out["scenes"][0];
  // The gain of the study's estimator is a median over independent repeats, inside its interval.
  EXPECT_EQ(scene["repeats"], 8);
  EXPECT_EQ(scene["adaptive"]["repeats"].size(), 8u);
  EXPECT_NE(scene["adaptive"]["repeats"][0]["relMse"], scene["adaptive"]["repeats"][1]["relMse"]) << "same seed twice";
  EXPECT_LE(scene["gainCi95"][0].get<double>(), scene["gain"].get<double>());
  EXPECT_GE(scene["gainCi95"][1].get<double>(), scene["gain"].get<double>());
  EXPECT_LT(scene["gainCi95"][0].get<double>(), scene["gainCi95"][1].get<double>());
  EXPECT_LT(scene["sobol"]["relMse"].get<double>(), scene["independent"]["relMse"].get<double>() / 2) << scene;
  EXPECT_EQ(scene["estimator"], "path");
  const test::CommandResult bad =
      test::runCommand(std::string(ARENA_BINARY) + " bench reference --scenes cornell_static --max-bounces 0");
  EXPECT_NE(bad.status, 0);
  EXPECT_NE(bad.output.find("--max-bounces"), std::string::npos) << bad.output;
}

TEST(Reference, BadSamplerSettingsAreErrorsNamingTheValue) {
  const Scene scene = test::shippedScene("cornell_static");
  RenderSettings s = referenceSettings("halton", 16);
  try {
    SequenceRenderer r(scene, s);
    FAIL() << "accepted an unknown sampler";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("'halton'"), std::string::npos) << e.what();
  }
  s.referenceSampler = "sobol";
  s.referenceReplicates = 1;
  EXPECT_THROW(SequenceRenderer(scene, s), Error);
}

}  // namespace
}  // namespace arena
