/* SPDX-License-Identifier: Apache-2.0 */
/*
 * Generator for the numeric constants in firmware/src/core/ef_math.c (atan polynomial) and
 * firmware/src/geom/ef_bezier.c (Gauss–Legendre nodes). Run: cc -O2 gen_fw_constants.c -lm &&
 * ./a.out The firmware's tests recompute both and compare, so a hand edit is caught.
 */
#include <math.h>
#include <stdio.h>

#define NT 8 /* polynomial terms: atan(a) ~ a * sum c_k (a^2)^k, a in [0,1] */

/* Least-squares fit on Chebyshev points, minimising relative error, then report max error. */
static void fit_atan(void)
{
    long double A[NT][NT] = {{0}}, r[NT] = {0};
    const int M = 4000;
    for (int i = 0; i < M; i++) {
        long double a =
            0.5L + 0.5L * cosl((2.0L * i + 1) * 3.14159265358979323846264L / (2.0L * M));
        long double s = a * a, y = atanl(a), basis[NT], p = a;
        for (int k = 0; k < NT; k++) {
            basis[k] = p;
            p *= s;
        }
        long double w = 1.0L / (a > 1e-3L ? a : 1e-3L); /* relative weighting near 0 */
        for (int j = 0; j < NT; j++) {
            r[j] += w * w * basis[j] * y;
            for (int k = 0; k < NT; k++)
                A[j][k] += w * w * basis[j] * basis[k];
        }
    }
    for (int c = 0; c < NT; c++) { /* Gaussian elimination with partial pivoting */
        int piv = c;
        for (int i = c + 1; i < NT; i++)
            if (fabsl(A[i][c]) > fabsl(A[piv][c]))
                piv = i;
        for (int k = 0; k < NT; k++) {
            long double t = A[c][k];
            A[c][k] = A[piv][k];
            A[piv][k] = t;
        }
        long double t = r[c];
        r[c] = r[piv];
        r[piv] = t;
        for (int i = c + 1; i < NT; i++) {
            long double f = A[i][c] / A[c][c];
            for (int k = c; k < NT; k++)
                A[i][k] -= f * A[c][k];
            r[i] -= f * r[c];
        }
    }
    long double c[NT];
    for (int i = NT - 1; i >= 0; i--) {
        long double s = r[i];
        for (int k = i + 1; k < NT; k++)
            s -= A[i][k] * c[k];
        c[i] = s / A[i][i];
    }
    printf("/* atan(a) ~ a * P(a^2) on [0,1] */\n");
    for (int k = 0; k < NT; k++)
        printf("    %.9ef,\n", (double)c[k]);
    double maxerr = 0;
    for (int i = 0; i <= 100000; i++) {
        float a = (float)i / 100000.0f, s = a * a, p = 0;
        for (int k = NT - 1; k >= 0; k--)
            p = p * s + (float)c[k];
        double e = fabs((double)(a * p) - atan((double)a));
        if (e > maxerr)
            maxerr = e;
    }
    printf("/* max abs error in float evaluation: %.3e */\n", maxerr);
}

/* Gauss–Legendre nodes on [0,1] by Newton iteration on P_n. */
static void gauss_legendre(int n)
{
    printf("/* n = %d */\n", n);
    for (int i = 0; i < n; i++) {
        long double x = cosl(3.14159265358979323846264L * (i + 0.75L) / (n + 0.5L)), dp = 0;
        for (int it = 0; it < 100; it++) {
            long double p0 = 1, p1 = x;
            for (int k = 2; k <= n; k++) {
                long double p2 = ((2 * k - 1) * x * p1 - (k - 1) * p0) / k;
                p0 = p1;
                p1 = p2;
            }
            if (n == 1)
                p0 = 1;
            dp = n * (x * p1 - p0) / (x * x - 1);
            long double dx = p1 / dp;
            x -= dx;
            if (fabsl(dx) < 1e-19L)
                break;
        }
        long double w = 2 / ((1 - x * x) * dp * dp);
        printf("    {%.9ef, %.9ef},\n", (double)((1 - x) / 2), (double)(w / 2));
    }
}

int main(void)
{
    fit_atan();
    static const int ns[] = {1, 3, 6, 9, 12, 15, 18};
    for (unsigned i = 0; i < sizeof ns / sizeof ns[0]; i++)
        gauss_legendre(ns[i]);
    return 0;
}
