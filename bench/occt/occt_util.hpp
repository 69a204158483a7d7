// What the Open CASCADE shims of the benchmarks share (bench/occt: occt_mesh.cpp, occt_tris.cpp,
// occt_faces.cpp): the file-kind sniff, the error text, the sample points of crisp's
// surface-accuracy test, and the guard that turns Open CASCADE's exceptions into an error code.
#ifndef CRISP_BENCH_OCCT_UTIL_HPP
#define CRISP_BENCH_OCCT_UTIL_HPP

#include <cstdio>
#include <cstring>
#include <exception>
#include <Message.hxx>
#include <Message_Messenger.hxx>
#include <Message_PrinterOStream.hxx>
#include <Standard_Failure.hxx>

namespace occt_util
{

// The sample points of crisp's surface-accuracy test: the centroid, the edge midpoints and three
// interior points.
constexpr double kBary[7][3] = {{1. / 3, 1. / 3, 1. / 3},
                                {.5, .5, 0},
                                {0, .5, .5},
                                {.5, 0, .5},
                                {.7, .2, .1},
                                {.1, .7, .2},
                                {.2, .1, .7}};

inline void fail(char *err, size_t size, const char *what, const char *detail)
{
    if (err && size)
        std::snprintf(err, size, "%s%s%s", what, detail ? ": " : "", detail ? detail : "");
}

// A STEP file (its header names ISO-10303-21); anything else is read as IGES.
inline bool is_step(const char *path)
{
    FILE *f = std::fopen(path, "rb");
    if (!f) return false;
    char buf[64] = {0};
    size_t n = std::fread(buf, 1, sizeof buf - 1, f);
    std::fclose(f);
    return n >= 13 && std::strstr(buf, "ISO-10303-21") != nullptr;
}

// Runs body() (returning 0 or an error code) with Open CASCADE's console printer removed (its
// readers and mesher report to stdout by default; the table is the output); an exception becomes
// 1 with its text in err.
template <class F> int guarded(char *err, size_t err_size, F body)
{
    try {
        Message::DefaultMessenger()->RemovePrinters(STANDARD_TYPE(Message_PrinterOStream));
        return body();
    } catch (const Standard_Failure &e) {
        fail(err, err_size, "Open CASCADE failed", e.GetMessageString());
    } catch (const std::exception &e) {
        fail(err, err_size, "Open CASCADE failed", e.what());
    } catch (...) {
        fail(err, err_size, "Open CASCADE failed", "unknown exception");
    }
    return 1;
}

} // namespace occt_util

#endif
