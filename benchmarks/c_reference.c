/* One pass of the labyrinthine tiling over one float32 plane, in C.
 *
 * The same readings as src/napari_labyrinth/core/_kernel.py, for a speed
 * reference: float64 arithmetic in the same order (build with
 * -ffp-contract=off so that no multiply-add is fused), the same SplitMix64
 * stream, the same option codes (core/codes.py) and diagnostic counts.
 * benchmarks/bench_kernel.py builds it, checks it bit for bit against the
 * kernel and times both. Written the way a C programmer would: the options
 * are run-time integers, the interior of a row is its own loop.
 */
#include <math.h>
#include <stdint.h>

enum { INSIDE, MIRROR, NEAREST, WRAP };
enum { SQRT_V_OVER_N, SQRT_V };
enum { LEAVE, PUSH_IN_RANGE, PUSH_FULL_SCALE };
enum { MEAN_FIRST, VARIANCE_FIRST };
enum { KEEP, LAST_DRAW };
enum { RASTER, SERPENTINE, CHECKERBOARD };
enum { KEPT_BY_MEAN, LEFT_BY_VARIANCE, PUSHED, REDRAWN, OUT_OF_TRIES, SKIPPED };

static inline uint64_t mix(uint64_t x)
{
    uint64_t z = x + 0x9E3779B97F4A7C15ULL;
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    return z ^ (z >> 31);
}

static inline double uniform(uint64_t pixel_key, int64_t attempt)
{
    return (double)(mix(pixel_key ^ (uint64_t)attempt) >> 11) * (1.0 / 9007199254740992.0);
}

static inline double ratio(double numerator, double mean)
{
    if (mean > 0.0)
        return numerator / mean;
    return numerator == 0.0 ? 0.0 : INFINITY;
}

static inline int64_t tone_range(double g, const double *bounds, int64_t n_ranges)
{
    int64_t i = 0;
    while (i < n_ranges - 1 && g >= bounds[i])
        i++;
    return i;
}

static inline int64_t border_index(int64_t i, int64_t n, int border)
{
    if (i >= 0 && i < n)
        return i;
    switch (border) {
    case INSIDE:
        return -1;
    case MIRROR:
        if (n == 1)
            return 0;
        return i < 0 ? -i : 2 * n - 2 - i;
    case NEAREST:
        return i < 0 ? 0 : n - 1;
    default:
        return ((i % n) + n) % n;
    }
}

typedef struct {
    double mean_threshold, variance_threshold;
    const double *bounds, *tone_low, *tone_high;
    int64_t n_ranges, max_tries;
    uint64_t key;
    int border, variance_ratio, variance_action, condition_order, on_exhausted, include_centre;
} options;

/* The decision for pixel (y, x) once its neighbours are known (Eq. 1-4). */
static inline __attribute__((always_inline)) int decide(float *plane, int64_t width, int64_t y, int64_t x, double g,
                         const double *values, int count, double neighbour_sum, const options *o)
{
    int n = o->include_centre ? count + 1 : count;
    double mean = o->include_centre ? (neighbour_sum + g) / n : neighbour_sum / n;
    double mean_ratio = ratio(fabs(g - mean), mean);
    int variance_first = o->condition_order == VARIANCE_FIRST;
    if (mean_ratio <= o->mean_threshold && !variance_first)
        return KEPT_BY_MEAN;
    double squares = 0.0;
    for (int k = 0; k < count; k++) {
        double deviation = values[k] - mean;
        squares += deviation * deviation;
    }
    if (o->include_centre)
        squares += (g - mean) * (g - mean);
    double variance = squares / n;
    double spread = sqrt(o->variance_ratio == SQRT_V_OVER_N ? variance / n : variance);
    uint64_t pixel_key = mix(o->key ^ (uint64_t)(y * width + x));
    if (ratio(spread, mean) > o->variance_threshold) {
        if (o->variance_action == LEAVE)
            return LEFT_BY_VARIANCE;
        int upward = g >= mean;
        double low, span;
        if (o->variance_action == PUSH_IN_RANGE) {
            int64_t i = tone_range(g, o->bounds, o->n_ranges);
            double tl = o->tone_low[i], th = o->tone_high[i];
            low = upward ? (mean >= tl ? mean : tl) : tl;
            span = (upward ? th : (mean <= th ? mean : th)) - low;
        } else {
            low = upward ? mean : o->tone_low[0];
            span = (upward ? o->tone_high[o->n_ranges - 1] : mean) - low;
        }
        for (int64_t attempt = 0; attempt < o->max_tries; attempt++) {
            float draw = (float)(low + uniform(pixel_key, attempt) * span);
            double candidate = (double)draw;
            double draw_mean = o->include_centre ? (neighbour_sum + candidate) / n : mean;
            int beyond = upward ? candidate > draw_mean : candidate < draw_mean;
            if (beyond && ratio(fabs(candidate - draw_mean), draw_mean) > mean_ratio) {
                plane[y * width + x] = draw;
                return PUSHED;
            }
        }
        return LEFT_BY_VARIANCE;
    }
    if (mean_ratio <= o->mean_threshold)
        return KEPT_BY_MEAN;
    int64_t i = tone_range(g, o->bounds, o->n_ranges);
    double low = o->tone_low[i], width_i = o->tone_high[i] - low;
    float draw = 0.0f;
    for (int64_t attempt = 0; attempt < o->max_tries; attempt++) {
        draw = (float)(low + uniform(pixel_key, attempt) * width_i);
        double candidate = (double)draw;
        double draw_mean = o->include_centre ? (neighbour_sum + candidate) / n : mean;
        if (ratio(fabs(candidate - draw_mean), draw_mean) <= o->mean_threshold) {
            plane[y * width + x] = draw;
            return REDRAWN;
        }
    }
    if (o->on_exhausted != KEEP && o->max_tries > 0)
        plane[y * width + x] = draw;
    return OUT_OF_TRIES;
}

/* A pixel of the interior of an all-finite plane: its 8 neighbours, row-major. */
static inline __attribute__((always_inline)) int interior_pixel(float *plane, int64_t width, int64_t y, int64_t x,
                                 const options *o)
{
    const float *above = plane + (y - 1) * width + x, *row = plane + y * width + x,
                *below = plane + (y + 1) * width + x;
    double values[8] = {above[-1], above[0], above[1], row[-1],
                        row[1],    below[-1], below[0], below[1]};
    double sum = values[0];
    for (int k = 1; k < 8; k++)
        sum += values[k];
    return decide(plane, width, y, x, (double)row[0], values, 8, sum, o);
}

/* Any pixel: the finite neighbours that count under the border mode. */
static inline int gathered_pixel(float *plane, int64_t height, int64_t width, int64_t y,
                                 int64_t x, const options *o)
{
    double g = plane[y * width + x];
    if (!isfinite(g))
        return SKIPPED;
    double values[8], sum = 0.0;
    int count = 0;
    for (int dy = -1; dy <= 1; dy++) {
        int64_t yy = border_index(y + dy, height, o->border);
        if (yy < 0)
            continue;
        for (int dx = -1; dx <= 1; dx++) {
            if (dy == 0 && dx == 0)
                continue;
            int64_t xx = border_index(x + dx, width, o->border);
            if (xx < 0)
                continue;
            double value = plane[yy * width + xx];
            if (isfinite(value)) {
                values[count++] = value;
                sum += value;
            }
        }
    }
    if (count == 0)
        return SKIPPED;
    return decide(plane, width, y, x, g, values, count, sum, o);
}

void labyrinth_pass(float *plane, int64_t height, int64_t width, double mean_threshold,
                    double variance_threshold, const double *range_bounds,
                    const double *tone_low, const double *tone_high, int64_t n_ranges,
                    int64_t max_tries, uint64_t seed, uint64_t plane_index, uint64_t pass_index,
                    int border, int variance_ratio, int variance_action, int condition_order,
                    int on_exhausted, int scan, int include_centre, int has_nonfinite,
                    int64_t *counts)
{
    options o = {mean_threshold, variance_threshold, range_bounds, tone_low, tone_high,
                 n_ranges, max_tries, mix(mix(mix(seed) ^ plane_index) ^ pass_index), border,
                 variance_ratio, variance_action, condition_order, on_exhausted, include_centre};
    int colours = scan == CHECKERBOARD ? 4 : 1;
    for (int colour = 0; colour < colours; colour++) {
        int64_t y_first = scan == CHECKERBOARD ? colour >> 1 : 0;
        int64_t y_step = scan == CHECKERBOARD ? 2 : 1;
        int64_t x_first = scan == CHECKERBOARD ? colour & 1 : 0;
        int64_t x_step = y_step;
        for (int64_t y = y_first; y < height; y += y_step) {
            int interior_row = !has_nonfinite && y > 0 && y < height - 1;
            if (scan == SERPENTINE && (y & 1)) {
                for (int64_t x = width - 1; x >= 0; x--) {
                    int code = interior_row && x > 0 && x < width - 1
                                   ? interior_pixel(plane, width, y, x, &o)
                                   : gathered_pixel(plane, height, width, y, x, &o);
                    counts[code]++;
                }
                continue;
            }
            if (!interior_row) {
                for (int64_t x = x_first; x < width; x += x_step)
                    counts[gathered_pixel(plane, height, width, y, x, &o)]++;
                continue;
            }
            int64_t x = x_first;
            if (x == 0) {
                counts[gathered_pixel(plane, height, width, y, 0, &o)]++;
                x += x_step;
            }
            for (; x < width - 1; x += x_step)
                counts[interior_pixel(plane, width, y, x, &o)]++;
            if (x == width - 1)
                counts[gathered_pixel(plane, height, width, y, x, &o)]++;
        }
    }
}
