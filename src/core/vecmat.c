/* Double-precision vectors and column-major 4x4 matrices for the geometry kernel
 * (gluLookAt / gluPerspective conventions, docs/design.md section 6). */
#include "crisp/core.h"

#include <math.h>
#include <string.h>

void crisp_vec2_sub(const crisp_vec2 a, const crisp_vec2 b, crisp_vec2 dest)
{
    dest[0] = a[0] - b[0];
    dest[1] = a[1] - b[1];
}

double crisp_vec2_dot(const crisp_vec2 a, const crisp_vec2 b)
{
    return a[0] * b[0] + a[1] * b[1];
}

double crisp_vec2_cross(const crisp_vec2 a, const crisp_vec2 b)
{
    return a[0] * b[1] - a[1] * b[0];
}

double crisp_vec2_norm(const crisp_vec2 a)
{
    return hypot(a[0], a[1]);
}

void crisp_vec3_add(const crisp_vec3 a, const crisp_vec3 b, crisp_vec3 dest)
{
    for (int i = 0; i < 3; i++)
        dest[i] = a[i] + b[i];
}

void crisp_vec3_sub(const crisp_vec3 a, const crisp_vec3 b, crisp_vec3 dest)
{
    for (int i = 0; i < 3; i++)
        dest[i] = a[i] - b[i];
}

void crisp_vec3_scale(const crisp_vec3 a, double s, crisp_vec3 dest)
{
    for (int i = 0; i < 3; i++)
        dest[i] = a[i] * s;
}

double crisp_vec3_dot(const crisp_vec3 a, const crisp_vec3 b)
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

void crisp_vec3_cross(const crisp_vec3 a, const crisp_vec3 b, crisp_vec3 dest)
{
    double x = a[1] * b[2] - a[2] * b[1];
    double y = a[2] * b[0] - a[0] * b[2];
    double z = a[0] * b[1] - a[1] * b[0];
    dest[0] = x;
    dest[1] = y;
    dest[2] = z;
}

double crisp_vec3_norm(const crisp_vec3 a)
{
    return sqrt(crisp_vec3_dot(a, a));
}

int crisp_vec3_normalize(const crisp_vec3 a, crisp_vec3 dest)
{
    double n = crisp_vec3_norm(a);
    if (!(n > 0) || !isfinite(n)) {
        dest[0] = dest[1] = dest[2] = 0;
        return 0;
    }
    crisp_vec3_scale(a, 1.0 / n, dest);
    return 1;
}

void crisp_vec4_scale(const crisp_vec4 a, double s, crisp_vec4 dest)
{
    for (int i = 0; i < 4; i++)
        dest[i] = a[i] * s;
}

double crisp_vec4_dot(const crisp_vec4 a, const crisp_vec4 b)
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3];
}

void crisp_mat4_identity(crisp_mat4 dest)
{
    memset(dest, 0, sizeof(crisp_mat4));
    for (int i = 0; i < 4; i++)
        dest[i][i] = 1;
}

void crisp_mat4_copy(crisp_mat4 m, crisp_mat4 dest)
{
    memmove(dest, m, sizeof(crisp_mat4));
}

void crisp_mat4_mul(crisp_mat4 a, crisp_mat4 b, crisp_mat4 dest)
{
    crisp_mat4 r;
    for (int c = 0; c < 4; c++)
        for (int row = 0; row < 4; row++) {
            double s = 0;
            for (int k = 0; k < 4; k++)
                s += a[k][row] * b[c][k];
            r[c][row] = s;
        }
    memcpy(dest, r, sizeof r);
}

void crisp_mat4_mulv(crisp_mat4 m, const crisp_vec4 v, crisp_vec4 dest)
{
    double r[4];
    for (int row = 0; row < 4; row++)
        r[row] = m[0][row] * v[0] + m[1][row] * v[1] + m[2][row] * v[2] + m[3][row] * v[3];
    memcpy(dest, r, sizeof r);
}

void crisp_mat4_mulp(crisp_mat4 m, const crisp_vec3 p, crisp_vec4 dest)
{
    crisp_vec4 v = {p[0], p[1], p[2], 1.0};
    crisp_mat4_mulv(m, v, dest);
}

void crisp_mat4_transpose(crisp_mat4 m, crisp_mat4 dest)
{
    crisp_mat4 r;
    for (int c = 0; c < 4; c++)
        for (int row = 0; row < 4; row++)
            r[row][c] = m[c][row];
    memcpy(dest, r, sizeof r);
}

int crisp_mat4_inverse(crisp_mat4 m, crisp_mat4 dest)
{
    /* Gauss-Jordan with partial pivoting on [m | I]. */
    double a[4][8];
    for (int r = 0; r < 4; r++)
        for (int c = 0; c < 4; c++) {
            a[r][c] = m[c][r];
            a[r][c + 4] = r == c;
        }
    for (int col = 0; col < 4; col++) {
        int piv = col;
        for (int r = col + 1; r < 4; r++)
            if (fabs(a[r][col]) > fabs(a[piv][col])) piv = r;
        if (!(fabs(a[piv][col]) > 0)) return 0;
        if (piv != col)
            for (int c = 0; c < 8; c++) {
                double t = a[col][c];
                a[col][c] = a[piv][c];
                a[piv][c] = t;
            }
        double inv = 1.0 / a[col][col];
        for (int c = 0; c < 8; c++)
            a[col][c] *= inv;
        for (int r = 0; r < 4; r++) {
            if (r == col) continue;
            double f = a[r][col];
            if (f != 0)
                for (int c = 0; c < 8; c++)
                    a[r][c] -= f * a[col][c];
        }
    }
    for (int r = 0; r < 4; r++)
        for (int c = 0; c < 4; c++)
            dest[c][r] = a[r][c + 4];
    return 1;
}

int crisp_mat4_lookat(const crisp_vec3 eye, const crisp_vec3 target, const crisp_vec3 up,
                      crisp_mat4 dest)
{
    crisp_vec3 f, s, u, d;
    crisp_vec3_sub(target, eye, d);
    if (!crisp_vec3_normalize(d, f)) return 0;
    crisp_vec3_cross(f, up, d);
    if (!crisp_vec3_normalize(d, s)) return 0;
    crisp_vec3_cross(s, f, u);
    crisp_mat4_identity(dest);
    for (int i = 0; i < 3; i++) {
        dest[i][0] = s[i];
        dest[i][1] = u[i];
        dest[i][2] = -f[i];
    }
    dest[3][0] = -crisp_vec3_dot(s, eye);
    dest[3][1] = -crisp_vec3_dot(u, eye);
    dest[3][2] = crisp_vec3_dot(f, eye);
    return 1;
}

void crisp_mat4_perspective(double fovy_deg, double aspect, double znear, double zfar,
                            crisp_mat4 dest)
{
    double f = 1.0 / tan(fovy_deg * (M_PI / 360.0));
    memset(dest, 0, sizeof(crisp_mat4));
    dest[0][0] = f / aspect;
    dest[1][1] = f;
    dest[2][2] = (zfar + znear) / (znear - zfar);
    dest[2][3] = -1;
    dest[3][2] = 2 * zfar * znear / (znear - zfar);
}
