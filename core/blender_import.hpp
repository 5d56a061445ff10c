#pragma once
// Blender Cycles as a producer of captures (`arena import blender`): reads what
// scripts/blender/render_capture.py writes -- multilayer EXRs of the noisy frames and of two
// independent reference halves, and the cameras -- and writes a capture (core/capture.hpp):
//   color       = Combined
//   diffuse     = DiffDir + DiffInd        albedo     = DiffCol   (Cycles divides the light passes
//   specular    = GlossDir + GlossInd      specAlbedo = GlossCol   by their colour pass, so these
//   emission    = Combined - albedo * diffuse - specAlbedo * specular     remodulate exactly)
//                 (Emit + Env and whatever other lobes -- transmission, volumes -- add)
//   normal      = Normal (world space; renormalised: at more than 1 spp Cycles averages a pixel's
//                 normals, shorter than 1 over an edge)
//   depth       = Depth.Z (view depth; background -> 0)
//   motion      = (Vector.X, -Vector.Y): Cycles' Vector.XY is the previous frame's raster position
//                 minus this one's with y up; ours is the same offset with y down
//   roughness   = the 'roughness' AOV the script's materials write
//   meshId      = IndexOB (object pass index; -1 on the background), materialId = IndexMA
//   reference   = the mean of the two halves; colorHalf = the first half (the noise floor); with
//                 one of reference_a/ and reference_b/, that one (no noise floor); with neither,
//                 no reference
// No specular hit distance: Cycles has no such pass; denoisers that need it fail on this capture
// with the channel named.
#include <filesystem>
#include <string>

namespace arena {

struct BlenderImportOptions {
  std::string name;  // the capture's name (default: the source folder's name)
  // The view layer to read (--view-layer); empty: the file's only one (several are refused).
  std::string viewLayer;
};

// Reads SOURCE (noisy/, reference_a/, reference_b/, cameras.json) and writes the capture to `out`.
void importBlender(const std::filesystem::path& source, const std::filesystem::path& out,
                   const BlenderImportOptions& options = {});

}  // namespace arena
