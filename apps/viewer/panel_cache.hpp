#pragma once
// The viewer's ImGui panel kept as a picture between redraws.
#include <vector>

struct ImDrawData;

namespace qbond::view {

/// The ImGui panel kept as a picture: its windows are rasterised into an offscreen framebuffer and
/// copied to the window each frame, and rasterised again only when their draw lists changed. With
/// software OpenGL (llvmpipe) the panel's blended, textured pixels take milliseconds a frame, more
/// than a small scene's 3D view; the copy takes a fraction of that. Needs a current context.
class PanelCache {
 public:
  PanelCache() = default;
  ~PanelCache();
  PanelCache(const PanelCache&) = delete;
  PanelCache& operator=(const PanelCache&) = delete;

  /// What draw_cached did: nothing, copied the kept picture, or rasterised it anew and copied it.
  enum class Drawn { no, copied, rasterised };
  /// Draws `d` into the panel, columns from x0 on [px] of the fb_w × fb_h default framebuffer,
  /// first filled with `background`: the cached picture is copied, redrawn first when the draw
  /// lists changed and `refresh` is set (a stale picture is kept until then). Draws nothing
  /// (`no`) when a window reaches left of x0 (help, the legend over the view, a tooltip).
  Drawn draw_cached(ImDrawData* d, int x0, int fb_w, int fb_h, const float (&background)[3], bool refresh);
  /// Draws `d` into the bound framebuffer as it is, the panel's columns filled first.
  static void draw_direct(ImDrawData* d, int x0, int fb_w, int fb_h, const float (&background)[3]);

 private:
  /// Whether `d` differs from the last rasterised draw lists; keeps `d`'s bytes in next_.
  bool changed(ImDrawData* d);

  unsigned fbo_ = 0, color_ = 0;
  int w_ = 0, h_ = 0, x0_ = -1;
  std::vector<char> last_, next_;
};

}  // namespace qbond::view
