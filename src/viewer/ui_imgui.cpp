// The viewer's panel with Dear ImGui: widgets built from a C model, actions returned as a C
// struct, and ImGui's triangles drawn on the CPU into an RGBA layer (the frame is a CPU image
// on its way to the swapchain anyway, so the panel needs no pipeline of its own).
#include "ui.h"

#include <imgui.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <new>
#include <vector>

namespace {

const int panel_width = 340;

struct press_state {
    bool down = false;     // the button as the window reports it
    bool pressed = false;  // went down since the last frame (held for one frame at least)
};

} // namespace

struct leap_ui {
    ImGuiContext *ctx = nullptr;
    std::vector<unsigned char> font;  // alpha, font_w x font_h
    int font_w = 0, font_h = 0;
    press_state buttons[3];
    bool log_counts = true;
    int drag_point = -1;   // the curve point being dragged
    int drag_handle = -1;  // 0 / 1: the value window's low / high handle
    char path[512] = "leap-tf.json";
};

namespace {

ImU32 rgba_u32(const float c[4], float alpha)
{
    auto b = [](float v) { return (int)std::lround(std::min(std::max(v, 0.0f), 1.0f) * 255.0f); };
    return IM_COL32(b(c[0]), b(c[1]), b(c[2]), b(alpha));
}

// ---- the transfer-function editor: opacity curve over the value histogram -------------------

struct canvas {
    ImVec2 p0, p1;
    double vmin, vmax;
    double x_of(double value) const { return p0.x + (value - vmin) / (vmax - vmin) * (p1.x - p0.x); }
    double value_of(double x) const { return vmin + (x - p0.x) / (p1.x - p0.x) * (vmax - vmin); }
    double y_of(double a) const { return p1.y - a * (p1.y - p0.y); }
    double a_of(double y) const { return (p1.y - y) / (p1.y - p0.y); }
};

void copy_points(const leap_ui_model *m, leap_ui_actions *a)
{
    if (a->points_changed) return;
    a->point_count = m->point_count;
    for (int i = 0; i < m->point_count; ++i) a->points[i][0] = m->points[i][0], a->points[i][1] = m->points[i][1];
}

void tf_editor(leap_ui *ui, const leap_ui_model *m, leap_ui_actions *a)
{
    ImDrawList *dl = ImGui::GetWindowDrawList();
    const float w = ImGui::GetContentRegionAvail().x, h = 150.0f;
    canvas c;
    c.p0 = ImGui::GetCursorScreenPos();
    c.p1 = ImVec2(c.p0.x + w, c.p0.y + h);
    c.vmin = m->value_min;
    c.vmax = m->value_max > m->value_min ? m->value_max : m->value_min + 1.0;
    ImGui::InvisibleButton("tf-editor", ImVec2(w, h), ImGuiButtonFlags_MouseButtonLeft | ImGuiButtonFlags_MouseButtonRight);
    const bool hovered = ImGui::IsItemHovered();
    dl->AddRectFilled(c.p0, c.p1, IM_COL32(24, 24, 28, 255));

    // histogram (log or linear counts) over the whole value range
    if (m->histogram) {
        double top = 0;
        for (int b = 0; b < m->bins; ++b) top = std::max(top, ui->log_counts ? std::log1p(m->histogram[b]) : m->histogram[b]);
        const double width = (m->hist_hi - m->hist_lo) / m->bins;
        for (int b = 0; top > 0 && b < m->bins; ++b) {
            const double v = ui->log_counts ? std::log1p(m->histogram[b]) : m->histogram[b];
            const float x0 = (float)std::max((double)c.p0.x, c.x_of(m->hist_lo + width * b));
            const float x1 = (float)std::min((double)c.p1.x, c.x_of(m->hist_lo + width * (b + 1)));
            dl->AddRectFilled(ImVec2(x0, (float)c.y_of(v / top)), ImVec2(x1, c.p1.y), IM_COL32(90, 90, 100, 255));
        }
    }
    // the value window: darker outside, handles at its ends
    const double lo = m->range[0], hi = m->range[1];
    const float xl = (float)std::min(std::max(c.x_of(lo), (double)c.p0.x), (double)c.p1.x);
    const float xh = (float)std::min(std::max(c.x_of(hi), (double)c.p0.x), (double)c.p1.x);
    dl->AddRectFilled(c.p0, ImVec2(xl, c.p1.y), IM_COL32(0, 0, 0, 110));
    dl->AddRectFilled(ImVec2(xh, c.p0.y), c.p1, IM_COL32(0, 0, 0, 110));
    dl->AddLine(ImVec2(xl, c.p0.y), ImVec2(xl, c.p1.y), IM_COL32(230, 200, 80, 255), 2.0f);
    dl->AddLine(ImVec2(xh, c.p0.y), ImVec2(xh, c.p1.y), IM_COL32(230, 200, 80, 255), 2.0f);

    // the curve: the edited points, or the applied table's opacity
    copy_points(m, a);
    std::vector<ImVec2> poly;
    if (a->point_count > 0) {
        poly.push_back(ImVec2(c.p0.x, (float)c.y_of(a->points[0][1])));
        for (int i = 0; i < a->point_count; ++i)
            poly.push_back(ImVec2((float)c.x_of(lo + a->points[i][0] * (hi - lo)), (float)c.y_of(a->points[i][1])));
        poly.push_back(ImVec2(c.p1.x, (float)c.y_of(a->points[a->point_count - 1][1])));
    } else if (m->tf_rgba) {
        for (int i = 0; i < LEAP_TF_TABLE_SIZE; i += 8)
            poly.push_back(ImVec2((float)c.x_of(lo + (hi - lo) * i / (LEAP_TF_TABLE_SIZE - 1)), (float)c.y_of(m->tf_rgba[i][3])));
    }
    dl->PushClipRect(c.p0, c.p1, true);
    if (poly.size() > 1) dl->AddPolyline(poly.data(), (int)poly.size(), IM_COL32(255, 255, 255, 255), 0, 1.5f);
    const ImVec2 mouse = ImGui::GetIO().MousePos;
    int near_point = -1;
    for (int i = 0; i < a->point_count; ++i) {
        const ImVec2 q((float)c.x_of(lo + a->points[i][0] * (hi - lo)), (float)c.y_of(a->points[i][1]));
        const float d = std::hypot(q.x - mouse.x, q.y - mouse.y);
        if (d < 7.0f && (near_point < 0 || hovered)) near_point = i;
        dl->AddCircleFilled(q, i == ui->drag_point || (hovered && i == near_point) ? 5.0f : 3.5f, IM_COL32(255, 255, 255, 255));
    }
    dl->PopClipRect();

    // mouse: drag a point, a window handle, or add a point; right click deletes a point
    const double u_mouse = hi > lo ? (c.value_of(mouse.x) - lo) / (hi - lo) : 0.0;
    const double a_mouse = std::min(std::max(c.a_of(mouse.y), 0.0), 1.0);
    if (ImGui::IsItemClicked(ImGuiMouseButton_Left)) {
        if (near_point >= 0) {
            ui->drag_point = near_point;
        } else if (std::fabs(mouse.x - xl) < 5.0f || std::fabs(mouse.x - xh) < 5.0f) {
            ui->drag_handle = std::fabs(mouse.x - xl) <= std::fabs(mouse.x - xh) ? 0 : 1;
        } else if (u_mouse > 0.0 && u_mouse < 1.0 && a->point_count < LEAP_TF_MAX_POINTS) {
            if (a->point_count == 0) { // start from the straight ramp the user sees the ends of
                a->point_count = 2;
                a->points[0][0] = 0.0, a->points[0][1] = m->tf_rgba ? m->tf_rgba[0][3] : 0.0;
                a->points[1][0] = 1.0, a->points[1][1] = m->tf_rgba ? m->tf_rgba[LEAP_TF_TABLE_SIZE - 1][3] : 1.0;
            }
            int at = 0;
            while (at < a->point_count && a->points[at][0] <= u_mouse) ++at;
            for (int i = a->point_count; i > at; --i) a->points[i][0] = a->points[i - 1][0], a->points[i][1] = a->points[i - 1][1];
            a->points[at][0] = u_mouse;
            a->points[at][1] = a_mouse;
            a->point_count++;
            a->points_changed = 1;
            ui->drag_point = at;
        }
    }
    if (!ImGui::IsMouseDown(ImGuiMouseButton_Left)) ui->drag_point = ui->drag_handle = -1;
    if (ui->drag_point >= 0 && ui->drag_point < a->point_count && ImGui::IsMouseDragging(ImGuiMouseButton_Left, 0.0f)) {
        const int i = ui->drag_point, n = a->point_count;
        const double left = i == 0 ? 0.0 : a->points[i - 1][0], right = i == n - 1 ? 1.0 : a->points[i + 1][0];
        if (i > 0 && i < n - 1) a->points[i][0] = std::min(std::max(u_mouse, left), right); // the ends stay at 0 and 1
        a->points[i][1] = a_mouse;
        a->points_changed = 1;
    }
    if (ui->drag_handle >= 0 && ImGui::IsMouseDragging(ImGuiMouseButton_Left, 0.0f)) {
        double v = std::min(std::max(c.value_of(mouse.x), c.vmin), c.vmax);
        a->range[0] = lo, a->range[1] = hi;
        a->range[ui->drag_handle] = v;
        if (a->range[1] > a->range[0]) a->range_changed = 1;
    }
    if (ImGui::IsItemClicked(ImGuiMouseButton_Right) && near_point > 0 && near_point < a->point_count - 1) {
        for (int i = near_point; i + 1 < a->point_count; ++i) a->points[i][0] = a->points[i + 1][0], a->points[i][1] = a->points[i + 1][1];
        a->point_count--;
        a->points_changed = 1;
    }
    if (hovered)
        ImGui::SetTooltip("value %.4g, opacity %.3f\nclick: add a point, drag: move it, right click: delete it\n"
                          "drag the yellow lines: value window",
                          c.value_of(mouse.x), a_mouse);
}

// The colour legend: the transfer function's colours over the value window, with ticks.
void legend(const leap_ui_model *m)
{
    if (!m->tf_rgba) return;
    ImDrawList *dl = ImGui::GetWindowDrawList();
    const float w = ImGui::GetContentRegionAvail().x, h = 14.0f;
    const ImVec2 p0 = ImGui::GetCursorScreenPos();
    for (int x = 0; x < (int)w; ++x) {
        const int i = (int)std::lround((double)x / std::max(w - 1.0f, 1.0f) * (LEAP_TF_TABLE_SIZE - 1));
        dl->AddRectFilled(ImVec2(p0.x + x, p0.y), ImVec2(p0.x + x + 1, p0.y + h), rgba_u32(m->tf_rgba[i], 1.0f));
    }
    ImGui::Dummy(ImVec2(w, h));
    ImGui::Text("%-10.4g %10.4g %10.4g", m->range[0], 0.5 * (m->range[0] + m->range[1]), m->range[1]);
}

// Segmentations: the objects with their colours (the legend) and a visibility box each.
void objects_section(const leap_ui_model *m, leap_ui_actions *a)
{
    size_t shown = 0, drawable = 0;
    for (size_t i = 0; i < m->object_count; ++i) {
        drawable += m->objects[i].drawable != 0;
        shown += m->objects[i].drawable && m->shown && m->shown[i];
    }
    ImGui::Text("%zu of %zu objects shown", shown, drawable);
    if (ImGui::Button("show all")) a->objects_all = 1;
    ImGui::SameLine();
    if (ImGui::Button("hide all")) a->objects_all = 0;
    ImGui::TextDisabled("click an object in the picture to pick it");
    const ImGuiTableFlags flags = ImGuiTableFlags_ScrollY | ImGuiTableFlags_RowBg | ImGuiTableFlags_BordersOuter;
    if (!ImGui::BeginTable("objects", 3, flags, ImVec2(0.0f, 260.0f))) return;
    ImGui::TableSetupScrollFreeze(0, 1);
    ImGui::TableSetupColumn("shown");
    ImGui::TableSetupColumn("ID");
    ImGui::TableSetupColumn("voxels");
    ImGui::TableHeadersRow();
    ImGuiListClipper clipper;
    clipper.Begin((int)m->object_count);
    while (clipper.Step())
        for (int i = clipper.DisplayStart; i < clipper.DisplayEnd; ++i) {
            const leap_ui_object &o = m->objects[i];
            ImGui::TableNextRow();
            ImGui::TableNextColumn();
            ImGui::PushID(i);
            if (o.drawable) {
                bool on = m->shown && m->shown[i];
                if (ImGui::Checkbox("##shown", &on)) a->object = i, a->object_shown = on;
                ImGui::SameLine();
                const float rgba[4] = {o.rgb[0], o.rgb[1], o.rgb[2], 1.0f};
                ImGui::ColorButton("##colour", ImVec4(rgba[0], rgba[1], rgba[2], rgba[3]), ImGuiColorEditFlags_NoTooltip,
                                   ImVec2(ImGui::GetFrameHeight(), ImGui::GetFrameHeight()));
            } else {
                ImGui::TextDisabled("background");
            }
            ImGui::PopID();
            ImGui::TableNextColumn();
            ImGui::Text("%lld", (long long)o.id);
            ImGui::TableNextColumn();
            ImGui::Text("%llu", (unsigned long long)o.voxels);
        }
    ImGui::EndTable();
}

void tf_section(leap_ui *ui, const leap_ui_model *m, leap_ui_actions *a)
{
    if (!ImGui::CollapsingHeader(m->labels ? "Objects" : "Transfer function", ImGuiTreeNodeFlags_DefaultOpen)) return;
    if (m->labels) {
        objects_section(m, a);
        return;
    }
    const char *current = m->preset >= 0 ? m->presets[m->preset] : m->tf_name;
    if (ImGui::BeginCombo("colour map", current)) {
        for (int i = 0; m->presets[i]; ++i)
            if (ImGui::Selectable(m->presets[i], i == m->preset)) a->preset = i;
        ImGui::EndCombo();
    }
    tf_editor(ui, m, a);
    legend(m);
    bool in_picture = m->show_legend != 0;
    if (ImGui::Checkbox("legend in the picture", &in_picture)) a->show_legend = in_picture;
    ImGui::Checkbox("log counts", &ui->log_counts);
    ImGui::SameLine();
    if (ImGui::Button("reset curve")) {
        a->points_changed = 1;
        a->point_count = 0;
    }
    double range[2] = {m->range[0], m->range[1]};
    const float speed = (float)((m->value_max - m->value_min) / 500.0);
    if (ImGui::DragScalarN("window", ImGuiDataType_Double, range, 2, speed, &m->value_min, &m->value_max, "%.4g") &&
        range[1] > range[0]) {
        a->range_changed = 1;
        a->range[0] = range[0], a->range[1] = range[1];
    }
    ImGui::Text("re-classify: %.1f ms", m->fig.classify_ms);
    ImGui::InputText("file", ui->path, sizeof ui->path);
    if (ImGui::Button("save JSON")) a->save_tf = 1;
    ImGui::SameLine();
    if (ImGui::Button("load JSON")) a->load_tf = 1;
    if (a->save_tf || a->load_tf) std::snprintf(a->path, sizeof a->path, "%s", ui->path);
}

void render_section(const leap_ui_model *m, leap_ui_actions *a)
{
    if (!ImGui::CollapsingHeader("Rendering", ImGuiTreeNodeFlags_DefaultOpen)) return;
    for (int i = 0; i < m->mode_count; ++i) {
        if (i) ImGui::SameLine();
        if (ImGui::RadioButton(m->mode_names[i], m->mode == i)) a->mode = i;
    }
    double step = m->step;
    const double step_min = 0.01, step_max = 64.0;
    if (ImGui::SliderScalar("step (voxels)", ImGuiDataType_Double, &step, &step_min, &step_max, "%.3g",
                            ImGuiSliderFlags_Logarithmic))
        a->step = step;
    int segments = m->max_segments;
    if (ImGui::SliderInt("segments/pixel", &segments, 1, m->segments_limit)) a->max_segments = segments;
    if (ImGui::IsItemHovered())
        ImGui::SetTooltip("sparseleap: segments stored per pixel; a pixel with more walks the occupancy tree");
    if (!m->labels) {
        static const char *const mips[] = {"off", "maximum", "minimum"};
        const int cur = m->mip > 0 ? 1 : m->mip < 0 ? 2 : 0;
        if (ImGui::BeginCombo("projection", mips[cur])) {
            for (int i = 0; i < 3; ++i)
                if (ImGui::Selectable(mips[i], i == cur)) a->mip = i == 1 ? 1 : i == 2 ? -1 : 0;
            ImGui::EndCombo();
        }
        bool shade = m->shade != 0;
        if (ImGui::Checkbox("shading", &shade)) a->shade = shade;
        ImGui::SameLine();
    }
    bool clip = m->clip_on != 0;
    if (ImGui::Checkbox("clipping plane", &clip)) a->clip = clip;
    if (ImGui::Button("reset camera")) a->reset_camera = 1;
    ImGui::SameLine();
    if (ImGui::Button("screenshot")) a->screenshot = LEAP_UI_SHOT_PLAIN;
    ImGui::SameLine();
    if (ImGui::Button("+ panel")) a->screenshot = LEAP_UI_SHOT_WITH_PANEL;
}

void figures_text(const leap_ui_model *m, bool wrap)
{
    const leap_ui_figures &f = m->fig;
    ImGui::Text("%ux%u%s  %.1f ms  %.1f fps", f.width, f.height, f.scale > 1 ? " (reduced)" : "", f.frame_ms,
                f.frame_ms > 0 ? 1000.0 / f.frame_ms : 0.0);
    ImGui::Text("GPU: raster %.1f  resolve %.1f  composite %.1f ms", f.raster_ms, f.resolve_ms, f.composite_ms);
    ImGui::Text("readback %.1f  compose %.1f  present %.1f ms", f.readback_ms, f.compose_ms, f.present_ms);
    ImGui::Text("%u boxes  %.1f samples/px  %.2f segments/px", f.boxes, f.samples_pp, f.segments_pp);
    ImGui::Text("overflowed pixels %u  volume on GPU %.1f MiB", f.overflowed, f.gpu_bytes / 1048576.0);
    if (f.cache_slots)
        ImGui::Text("brick cache %u slots, %.1f MiB%s", f.cache_slots, f.cache_bytes / 1048576.0,
                    f.cache_over ? " (above --gpu-cache: one whole layer at least)" : "");
    // the panel wraps; the figures window alone sizes itself to its text, so it must not
    if (m->hover && m->hover[0] && wrap) ImGui::TextWrapped("cursor: %s", m->hover);
    else if (m->hover && m->hover[0]) ImGui::Text("cursor: %s", m->hover);
}

} // namespace

extern "C" {

leap_result leap_ui_create(leap_ui **out, leap_error *err)
{
    *out = nullptr;
    leap_ui *ui = new (std::nothrow) leap_ui;
    if (!ui) return leap_fail(err, LEAP_ERR_OOM, "out of memory for the panel");
    ui->ctx = ImGui::CreateContext();
    ImGui::SetCurrentContext(ui->ctx);
    ImGuiIO &io = ImGui::GetIO();
    io.IniFilename = nullptr; // no imgui.ini in the user's directory
    io.LogFilename = nullptr;
    io.KeyMap[ImGuiKey_Backspace] = LEAP_UI_KEY_BACKSPACE;
    io.KeyMap[ImGuiKey_Delete] = LEAP_UI_KEY_DELETE;
    io.KeyMap[ImGuiKey_Enter] = LEAP_UI_KEY_ENTER;
    io.KeyMap[ImGuiKey_LeftArrow] = LEAP_UI_KEY_LEFT;
    io.KeyMap[ImGuiKey_RightArrow] = LEAP_UI_KEY_RIGHT;
    io.KeyMap[ImGuiKey_Home] = LEAP_UI_KEY_HOME;
    io.KeyMap[ImGuiKey_End] = LEAP_UI_KEY_END;
    io.KeyMap[ImGuiKey_Tab] = LEAP_UI_KEY_TAB;
    io.KeyMap[ImGuiKey_Escape] = LEAP_UI_KEY_ESCAPE;
    ImGui::StyleColorsDark();
    ImGui::GetStyle().WindowRounding = 0.0f;
    unsigned char *pixels = nullptr;
    io.Fonts->GetTexDataAsAlpha8(&pixels, &ui->font_w, &ui->font_h);
    ui->font.assign(pixels, pixels + (size_t)ui->font_w * ui->font_h);
    io.Fonts->SetTexID((ImTextureID)(intptr_t)1);
    io.MousePos = ImVec2(-FLT_MAX, -FLT_MAX);
    *out = ui;
    return LEAP_OK;
}

void leap_ui_destroy(leap_ui *ui)
{
    if (!ui) return;
    ImGui::DestroyContext(ui->ctx);
    delete ui;
}

void leap_ui_mouse_move(leap_ui *ui, double x, double y)
{
    ImGui::SetCurrentContext(ui->ctx);
    ImGui::GetIO().MousePos = ImVec2((float)x, (float)y);
}

void leap_ui_mouse_button(leap_ui *ui, int button, int down)
{
    if (button < 0 || button > 2) return;
    ui->buttons[button].down = down != 0;
    if (down) ui->buttons[button].pressed = true;
}

void leap_ui_scroll(leap_ui *ui, double clicks)
{
    ImGui::SetCurrentContext(ui->ctx);
    ImGui::GetIO().MouseWheel += (float)clicks;
}

void leap_ui_char(leap_ui *ui, unsigned codepoint)
{
    ImGui::SetCurrentContext(ui->ctx);
    ImGui::GetIO().AddInputCharacter(codepoint);
}

void leap_ui_key(leap_ui *ui, int key, int down)
{
    if (key <= 0 || key >= 512) return;
    ImGui::SetCurrentContext(ui->ctx);
    ImGui::GetIO().KeysDown[key] = down != 0;
}

int leap_ui_wants_mouse(const leap_ui *ui)
{
    ImGui::SetCurrentContext(ui->ctx);
    return ImGui::GetIO().WantCaptureMouse;
}

int leap_ui_wants_keyboard(const leap_ui *ui)
{
    ImGui::SetCurrentContext(ui->ctx);
    return ImGui::GetIO().WantTextInput;
}

void leap_ui_frame(leap_ui *ui, const leap_ui_model *m, double dt, leap_ui_actions *a)
{
    std::memset(a, 0, sizeof *a);
    a->mode = a->preset = -1;
    a->mip = -2;
    a->shade = a->clip = a->show_panel = a->show_figures = a->show_legend = -1;
    a->object = -1;
    a->objects_all = -1;
    ImGui::SetCurrentContext(ui->ctx);
    ImGuiIO &io = ImGui::GetIO();
    io.DisplaySize = ImVec2((float)std::max(m->width, 1), (float)std::max(m->height, 1));
    io.DeltaTime = dt > 0 ? (float)dt : 1.0f / 60.0f;
    for (int b = 0; b < 3; ++b) {
        io.MouseDown[b] = ui->buttons[b].down || ui->buttons[b].pressed; // a quick click lasts one frame
        ui->buttons[b].pressed = false;
    }
    ImGui::NewFrame();
    if (m->show_panel) {
        ImGui::SetNextWindowPos(ImVec2(0, 0), ImGuiCond_Always);
        ImGui::SetNextWindowSize(ImVec2((float)std::min(panel_width, std::max(m->width, 1)), (float)m->height),
                                 ImGuiCond_Always);
        bool open = true;
        ImGui::Begin("leap", &open, ImGuiWindowFlags_NoMove | ImGuiWindowFlags_NoResize | ImGuiWindowFlags_NoCollapse);
        ImGui::TextUnformatted(m->volume_name);
        if (m->blank && m->blank[0]) {
            ImGui::PushStyleColor(ImGuiCol_Text, IM_COL32(255, 110, 90, 255));
            ImGui::TextWrapped("NOTHING TO SHOW: %s", m->blank);
            ImGui::PopStyleColor();
        }
        tf_section(ui, m, a);
        render_section(m, a);
        if (ImGui::CollapsingHeader("Figures", ImGuiTreeNodeFlags_DefaultOpen)) figures_text(m, true);
        if (m->message && m->message[0]) ImGui::TextWrapped("%s", m->message);
        ImGui::TextDisabled("p: panel  f: figures  ?: keys");
        ImGui::End();
        if (!open) a->show_panel = 0;
    } else if (m->show_figures || (m->blank && m->blank[0])) {
        ImGui::SetNextWindowPos(ImVec2(8, 8), ImGuiCond_Always);
        ImGui::SetNextWindowBgAlpha(0.6f);
        ImGui::Begin("figures", nullptr,
                     ImGuiWindowFlags_NoDecoration | ImGuiWindowFlags_AlwaysAutoResize | ImGuiWindowFlags_NoMove |
                         ImGuiWindowFlags_NoFocusOnAppearing | ImGuiWindowFlags_NoNav);
        if (m->blank && m->blank[0]) ImGui::TextColored(ImVec4(1.0f, 0.43f, 0.35f, 1.0f), "NOTHING TO SHOW: %s", m->blank);
        if (m->show_figures) figures_text(m, false);
        ImGui::End();
    }
    ImGui::Render();
    io.MouseWheel = 0;
}

} // extern "C"

// ---- CPU rasterisation of ImGui's triangles --------------------------------------------------

namespace {

struct layer {
    uint8_t *px;
    int w, h;
};

inline void blend(uint8_t *d, const float c[4], float a)
{
    for (int k = 0; k < 3; ++k) d[k] = (uint8_t)(c[k] * a + d[k] * (1.0f - a) + 0.5f);
    d[3] = (uint8_t)(255.0f * a + d[3] * (1.0f - a) + 0.5f);
}

inline float texel(const leap_ui *ui, float u, float v)
{
    const int tx = std::min(std::max((int)(u * ui->font_w), 0), ui->font_w - 1);
    const int ty = std::min(std::max((int)(v * ui->font_h), 0), ui->font_h - 1);
    return ui->font[(size_t)ty * ui->font_w + tx] * (1.0f / 255.0f);
}

// Most of ImGui's pixels come as axis-aligned quads of one colour (fills, glyphs): two
// triangles a b c, a c d. Drawn as a rectangle with the texture mapped linearly; 0 if the
// six indices are no such quad.
int rectangle(const leap_ui *ui, layer &L, const ImDrawVert *vtx, const ImDrawIdx *idx, const ImVec4 &clip)
{
    if (idx[3] != idx[0] || idx[4] != idx[2]) return 0;
    const ImDrawVert &a = vtx[idx[0]], &b = vtx[idx[1]], &c = vtx[idx[2]], &d = vtx[idx[5]];
    if (a.col != b.col || a.col != c.col || a.col != d.col) return 0;
    // a and c opposite corners; b and d share one coordinate with each
    const bool horizontal = a.pos.y == b.pos.y && b.pos.x == c.pos.x && c.pos.y == d.pos.y && d.pos.x == a.pos.x;
    if (!horizontal || a.pos.x == c.pos.x || a.pos.y == c.pos.y) return 0;
    if (a.uv.y != b.uv.y || b.uv.x != c.uv.x || c.uv.y != d.uv.y || d.uv.x != a.uv.x) return 0;
    const float x0 = std::min(a.pos.x, c.pos.x), x1 = std::max(a.pos.x, c.pos.x);
    const float y0 = std::min(a.pos.y, c.pos.y), y1 = std::max(a.pos.y, c.pos.y);
    const int px0 = std::max((int)std::ceil(std::max(x0, clip.x) - 0.5f), 0);
    const int py0 = std::max((int)std::ceil(std::max(y0, clip.y) - 0.5f), 0);
    const int px1 = std::min((int)std::ceil(std::min(x1, clip.z) - 0.5f), L.w);
    const int py1 = std::min((int)std::ceil(std::min(y1, clip.w) - 0.5f), L.h);
    const float c4[4] = {(float)(a.col & 0xff), (float)(a.col >> 8 & 0xff), (float)(a.col >> 16 & 0xff),
                         (float)(a.col >> 24 & 0xff)};
    if (a.uv.x == c.uv.x && a.uv.y == c.uv.y) { // a solid fill: one colour, blended in integers
        const int alpha = (int)(c4[3] * texel(ui, a.uv.x, a.uv.y) + 0.5f);
        if (alpha <= 0) return 1;
        int src[4];
        for (int k = 0; k < 3; ++k) src[k] = ((int)c4[k] * alpha + 127) / 255;
        src[3] = alpha;
        for (int y = py0; y < py1; ++y) {
            uint8_t *d = L.px + 4 * ((size_t)y * L.w + px0);
            for (int x = px0; x < px1; ++x, d += 4)
                for (int k = 0; k < 4; ++k) d[k] = (uint8_t)(src[k] + (d[k] * (255 - alpha) + 127) / 255);
        }
        return 1;
    }
    // uv at pixel centre: linear from corner a to corner c
    const float du = (c.uv.x - a.uv.x) / (c.pos.x - a.pos.x), dv = (c.uv.y - a.uv.y) / (c.pos.y - a.pos.y);
    for (int y = py0; y < py1; ++y) {
        const float v = a.uv.y + (y + 0.5f - a.pos.y) * dv;
        uint8_t *row = L.px + 4 * (size_t)y * L.w;
        for (int x = px0; x < px1; ++x) {
            const float alpha = c4[3] / 255.0f * texel(ui, a.uv.x + (x + 0.5f - a.pos.x) * du, v);
            if (alpha > 0) blend(row + 4 * x, c4, alpha);
        }
    }
    return 1;
}

inline float edge(const ImVec2 &a, const ImVec2 &b, float x, float y)
{
    return (b.x - a.x) * (y - a.y) - (b.y - a.y) * (x - a.x);
}

void triangle(const leap_ui *ui, layer &L, const ImDrawVert &v0, const ImDrawVert &v1, const ImDrawVert &v2,
              const ImVec4 &clip)
{
    const float area = edge(v0.pos, v1.pos, v2.pos.x, v2.pos.y);
    if (std::fabs(area) < 1e-6f) return;
    int x0 = (int)std::floor(std::max({std::min({v0.pos.x, v1.pos.x, v2.pos.x}), clip.x, 0.0f}));
    int y0 = (int)std::floor(std::max({std::min({v0.pos.y, v1.pos.y, v2.pos.y}), clip.y, 0.0f}));
    int x1 = (int)std::ceil(std::min({std::max({v0.pos.x, v1.pos.x, v2.pos.x}), clip.z, (float)L.w}));
    int y1 = (int)std::ceil(std::min({std::max({v0.pos.y, v1.pos.y, v2.pos.y}), clip.w, (float)L.h}));
    const float inv = 1.0f / area;
    auto chan = [](ImU32 c, int s) { return (float)((c >> s) & 0xff); };
    const ImVec2 *p[3] = {&v0.pos, &v1.pos, &v2.pos};
    for (int y = y0; y < y1; ++y) {
        // the row's span inside the triangle (slivers of long lines would waste a whole box)
        const float py = y + 0.5f;
        float lo = 1e30f, hi = -1e30f;
        for (int e = 0; e < 3; ++e) {
            const ImVec2 &a = *p[e], &b = *p[(e + 1) % 3];
            if ((a.y <= py && b.y >= py) || (b.y <= py && a.y >= py)) {
                const float x = a.y == b.y ? std::min(a.x, b.x) : a.x + (py - a.y) / (b.y - a.y) * (b.x - a.x);
                const float x2 = a.y == b.y ? std::max(a.x, b.x) : x;
                lo = std::min(lo, x);
                hi = std::max(hi, x2);
            }
        }
        if (!(lo <= hi)) continue; // the row misses the triangle
        // clamped before the conversion: a float beyond int's range does not convert
        const int xa = (int)std::max((float)x0, std::floor(lo - 1.0f)), xb = (int)std::min((float)x1, std::ceil(hi + 1.0f));
        for (int x = xa; x < xb; ++x) {
            const float px = x + 0.5f;
            const float w0 = edge(v1.pos, v2.pos, px, py) * inv, w1 = edge(v2.pos, v0.pos, px, py) * inv;
            const float w2 = 1.0f - w0 - w1;
            if (w0 < 0 || w1 < 0 || w2 < 0) continue;
            const float u = w0 * v0.uv.x + w1 * v1.uv.x + w2 * v2.uv.x, v = w0 * v0.uv.y + w1 * v1.uv.y + w2 * v2.uv.y;
            float c[4];
            for (int k = 0; k < 4; ++k) c[k] = w0 * chan(v0.col, 8 * k) + w1 * chan(v1.col, 8 * k) + w2 * chan(v2.col, 8 * k);
            const float a = c[3] / 255.0f * texel(ui, u, v);
            if (a > 0) blend(L.px + 4 * ((size_t)y * L.w + x), c, a);
        }
    }
}

} // namespace

extern "C" int leap_ui_draw(const leap_ui *ui, uint8_t *rgba, int w, int h)
{
    std::memset(rgba, 0, (size_t)w * h * 4);
    ImGui::SetCurrentContext(ui->ctx);
    const ImDrawData *dd = ImGui::GetDrawData();
    if (!dd || !dd->Valid) return 0;
    layer L{rgba, w, h};
    int drawn = 0;
    for (int l = 0; l < dd->CmdListsCount; ++l) {
        const ImDrawList *list = dd->CmdLists[l];
        for (const ImDrawCmd &cmd : list->CmdBuffer) {
            if (cmd.UserCallback) continue;
            const ImDrawVert *vtx = list->VtxBuffer.Data + cmd.VtxOffset;
            for (unsigned i = 0; i + 2 < cmd.ElemCount; i += 3) {
                const ImDrawIdx *idx = list->IdxBuffer.Data + cmd.IdxOffset + i;
                drawn = 1;
                if (i + 5 < cmd.ElemCount && rectangle(ui, L, vtx, idx, cmd.ClipRect)) {
                    i += 3; // both triangles
                    continue;
                }
                triangle(ui, L, vtx[idx[0]], vtx[idx[1]], vtx[idx[2]], cmd.ClipRect);
            }
        }
    }
    return drawn;
}
