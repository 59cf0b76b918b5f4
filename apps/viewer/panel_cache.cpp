#include "panel_cache.hpp"

#include "gl.hpp"
#include <imgui.h>
#include <imgui_impl_opengl3.h>

#include <algorithm>
#include <cstring>

namespace qbond::view {

namespace {

void append(std::vector<char>& out, const void* p, std::size_t n) {
  const char* c = static_cast<const char*>(p);
  out.insert(out.end(), c, c + n);
}

/// Fills columns [x0, fb_w) of the bound framebuffer with `rgb`.
void fill(int x0, int fb_w, int fb_h, const float (&rgb)[3]) {
  glEnable(GL_SCISSOR_TEST);
  glScissor(x0, 0, fb_w - x0, fb_h);
  glClearColor(rgb[0], rgb[1], rgb[2], 1);
  glClear(GL_COLOR_BUFFER_BIT);
  glDisable(GL_SCISSOR_TEST);
}

}  // namespace

PanelCache::~PanelCache() {
  if (fbo_) glDeleteFramebuffers(1, &fbo_);
  if (color_) glDeleteRenderbuffers(1, &color_);
}

bool PanelCache::changed(ImDrawData* d) {
  next_.clear();
  append(next_, &d->DisplayPos, sizeof d->DisplayPos);
  append(next_, &d->DisplaySize, sizeof d->DisplaySize);
  for (int l = 0; l < d->CmdListsCount; ++l) {
    const ImDrawList* list = d->CmdLists[l];
    append(next_, list->VtxBuffer.Data, static_cast<std::size_t>(list->VtxBuffer.Size) * sizeof(ImDrawVert));
    append(next_, list->IdxBuffer.Data, static_cast<std::size_t>(list->IdxBuffer.Size) * sizeof(ImDrawIdx));
    for (const ImDrawCmd& c : list->CmdBuffer) {
      append(next_, &c.ClipRect, sizeof c.ClipRect);
      append(next_, &c.TextureId, sizeof c.TextureId);
      append(next_, &c.VtxOffset, sizeof c.VtxOffset);
      append(next_, &c.IdxOffset, sizeof c.IdxOffset);
      append(next_, &c.ElemCount, sizeof c.ElemCount);
    }
  }
  return next_.size() != last_.size() || std::memcmp(next_.data(), last_.data(), next_.size()) != 0;
}

void PanelCache::draw_direct(ImDrawData* d, int x0, int fb_w, int fb_h, const float (&background)[3]) {
  fill(std::max(0, std::min(x0, fb_w)), fb_w, fb_h, background);
  ImGui_ImplOpenGL3_RenderDrawData(d);
}

PanelCache::Drawn PanelCache::draw_cached(ImDrawData* d, int x0, int fb_w, int fb_h, const float (&background)[3],
                                          bool refresh) {
  x0 = std::max(0, std::min(x0, fb_w));
  bool inside = true;  // every vertex within the panel's columns (clip rects may span the screen)
  const float left = (static_cast<float>(x0) - 0.5f) / d->FramebufferScale.x + d->DisplayPos.x;
  for (int l = 0; l < d->CmdListsCount && inside; ++l)
    for (const ImDrawVert& v : d->CmdLists[l]->VtxBuffer)
      if (v.pos.x < left) {
        inside = false;
        break;
      }
  if (!inside) {
    last_.clear();  // the picture is not kept: redraw it when the panel is alone again
    return Drawn::no;
  }
  bool redraw = false;
  if (fb_w != w_ || fb_h != h_ || x0 != x0_) {  // a new size: a new picture, drawn now
    if (!fbo_) glGenFramebuffers(1, &fbo_), glGenRenderbuffers(1, &color_);
    glBindRenderbuffer(GL_RENDERBUFFER, color_);
    glRenderbufferStorage(GL_RENDERBUFFER, GL_RGBA8, fb_w, fb_h);
    glBindFramebuffer(GL_FRAMEBUFFER, fbo_);
    glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, color_);
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    w_ = fb_w, h_ = fb_h, x0_ = x0;
    last_.clear();
    redraw = true;
  }
  if (changed(d) && (refresh || last_.empty())) redraw = true;
  glBindFramebuffer(GL_FRAMEBUFFER, fbo_);
  if (redraw) {
    fill(x0, fb_w, fb_h, background);
    ImGui_ImplOpenGL3_RenderDrawData(d);
    last_.swap(next_);
  }
  glBindFramebuffer(GL_READ_FRAMEBUFFER, fbo_);
  glBindFramebuffer(GL_DRAW_FRAMEBUFFER, 0);
  glDisable(GL_SCISSOR_TEST);
  glBlitFramebuffer(x0, 0, fb_w, fb_h, x0, 0, fb_w, fb_h, GL_COLOR_BUFFER_BIT, GL_NEAREST);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  return redraw ? Drawn::rasterised : Drawn::copied;
}

}  // namespace qbond::view
