// Dear ImGui behind the C header ui.h (the only C++ of the window apps, like src/osd's shim).
#include "ui.h"

#include <cstdarg>
#include <cstdio>

#include <imgui.h>
#include <backends/imgui_impl_glfw.h>
#include <backends/imgui_impl_opengl3.h>

static int ui_ready;

int app_ui_init(GLFWwindow *w)
{
    IMGUI_CHECKVERSION();
    ImGui::CreateContext();
    ImGuiIO &io = ImGui::GetIO();
    io.IniFilename = nullptr; // no imgui.ini written beside the user's files
    ImGui::StyleColorsDark();
    ImGui::GetStyle().Alpha = 0.92f;
    if (!ImGui_ImplGlfw_InitForOpenGL(w, false)) return 0;
    if (!ImGui_ImplOpenGL3_Init("#version 450 core")) return 0;
    ui_ready = 1;
    return 1;
}

void app_ui_shutdown(void)
{
    if (!ui_ready) return;
    ImGui_ImplOpenGL3_Shutdown();
    ImGui_ImplGlfw_Shutdown();
    ImGui::DestroyContext();
    ui_ready = 0;
}

void app_ui_frame_begin(void)
{
    ImGui_ImplOpenGL3_NewFrame();
    ImGui_ImplGlfw_NewFrame();
    ImGui::NewFrame();
}

void app_ui_frame_end(void)
{
    ImGui::Render();
    ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
}

int app_ui_wants_mouse(void)
{
    return ui_ready && ImGui::GetIO().WantCaptureMouse;
}
int app_ui_wants_keyboard(void)
{
    return ui_ready && ImGui::GetIO().WantCaptureKeyboard;
}

void app_ui_on_button(GLFWwindow *w, int button, int action, int mods)
{
    if (ui_ready) ImGui_ImplGlfw_MouseButtonCallback(w, button, action, mods);
}
void app_ui_on_scroll(GLFWwindow *w, double dx, double dy)
{
    if (ui_ready) ImGui_ImplGlfw_ScrollCallback(w, dx, dy);
}
void app_ui_on_key(GLFWwindow *w, int key, int scancode, int action, int mods)
{
    if (ui_ready) ImGui_ImplGlfw_KeyCallback(w, key, scancode, action, mods);
}
void app_ui_on_char(GLFWwindow *w, unsigned int c)
{
    if (ui_ready) ImGui_ImplGlfw_CharCallback(w, c);
}

int app_ui_begin(const char *title, float x, float y, float width, int flags)
{
    ImGuiIO &io = ImGui::GetIO();
    ImVec2 pivot(x < 0 ? 1.0f : 0.0f, y < 0 ? 1.0f : 0.0f);
    ImVec2 pos(x < 0 ? io.DisplaySize.x + x : x, y < 0 ? io.DisplaySize.y + y : y);
    ImGuiWindowFlags f = ImGuiWindowFlags_AlwaysAutoResize;
    if (flags & APP_UI_OVERLAY) {
        f |= ImGuiWindowFlags_NoDecoration | ImGuiWindowFlags_NoInputs |
             ImGuiWindowFlags_NoFocusOnAppearing | ImGuiWindowFlags_NoNav |
             ImGuiWindowFlags_NoSavedSettings;
        ImGui::SetNextWindowPos(pos, ImGuiCond_Always, pivot);
        ImGui::SetNextWindowBgAlpha(0.55f);
    } else {
        ImGui::SetNextWindowPos(pos, ImGuiCond_FirstUseEver, pivot);
    }
    if (width > 0) ImGui::SetNextWindowSizeConstraints(ImVec2(width, 0), ImVec2(width, 1e6f));
    return ImGui::Begin(title, nullptr, f);
}

void app_ui_end(void)
{
    ImGui::End();
}

void app_ui_text(const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    ImGui::TextV(fmt, ap);
    va_end(ap);
}

void app_ui_text_color(float r, float g, float b, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    ImGui::TextColoredV(ImVec4(r, g, b, 1), fmt, ap);
    va_end(ap);
}

void app_ui_wrapped(const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    ImGui::TextWrappedV(fmt, ap);
    va_end(ap);
}

int app_ui_button(const char *label)
{
    return ImGui::Button(label);
}

int app_ui_checkbox(const char *label, int *value)
{
    bool b = *value != 0;
    bool changed = ImGui::Checkbox(label, &b);
    *value = b;
    return changed;
}

void app_ui_same_line(void)
{
    ImGui::SameLine();
}
void app_ui_separator(void)
{
    ImGui::Separator();
}
void app_ui_progress(float fraction, const char *overlay)
{
    ImGui::ProgressBar(fraction, ImVec2(-1, 0), overlay);
}

int app_ui_tree_node(const char *label, int leaf, int selected, int *clicked)
{
    ImGuiTreeNodeFlags f = ImGuiTreeNodeFlags_OpenOnArrow | ImGuiTreeNodeFlags_SpanAvailWidth;
    if (leaf) f |= ImGuiTreeNodeFlags_Leaf | ImGuiTreeNodeFlags_NoTreePushOnOpen;
    if (selected) f |= ImGuiTreeNodeFlags_Selected;
    bool open = ImGui::TreeNodeEx(label, f);
    if (clicked) *clicked = ImGui::IsItemClicked();
    return open && !leaf;
}

void app_ui_tree_pop(void)
{
    ImGui::TreePop();
}

void app_ui_line(float x0, float y0, float x1, float y1, uint32_t color, float thickness)
{
    ImGui::GetForegroundDrawList()->AddLine(ImVec2(x0, y0), ImVec2(x1, y1), color, thickness);
}

void app_ui_circle(float x, float y, float r, uint32_t color, int filled)
{
    ImDrawList *d = ImGui::GetForegroundDrawList();
    if (filled)
        d->AddCircleFilled(ImVec2(x, y), r, color);
    else
        d->AddCircle(ImVec2(x, y), r, color, 0, 1.5f);
}

void app_ui_label(float x, float y, uint32_t color, const char *text)
{
    ImGui::GetForegroundDrawList()->AddText(ImVec2(x, y), color, text);
}

void app_ui_canvas(float w, float h, float origin[2])
{
    ImVec2 p = ImGui::GetCursorScreenPos();
    ImGui::InvisibleButton("##canvas", ImVec2(w, h));
    origin[0] = p.x;
    origin[1] = p.y;
}

void app_ui_wline(float x0, float y0, float x1, float y1, uint32_t color, float thickness)
{
    ImGui::GetWindowDrawList()->AddLine(ImVec2(x0, y0), ImVec2(x1, y1), color, thickness);
}

void app_ui_wrect(float x0, float y0, float x1, float y1, uint32_t color)
{
    ImGui::GetWindowDrawList()->AddRectFilled(ImVec2(x0, y0), ImVec2(x1, y1), color);
}

void app_ui_bline(float x0, float y0, float x1, float y1, uint32_t color, float thickness)
{
    ImGui::GetBackgroundDrawList()->AddLine(ImVec2(x0, y0), ImVec2(x1, y1), color, thickness);
}
