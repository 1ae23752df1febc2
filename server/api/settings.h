/* settings.h: the daemon's settings, each defined once in SRV_SETTINGS below.
 *
 * From that one table come the srv_settings struct, the SRV_SET_* bits, the defaults, the
 * JSON view and the strict JSON patch parser (protocol/openapi.yaml, schema Settings, which
 * tests/server/test_settings_table.c checks against the table), the range checks of a patch,
 * the setting flags of `probecast serve`, `render` and `eval` (its sweeps as lists) with their
 * usage text (tests/server/test_settings_cli.c), and the world/view scope of each setting. Where the renderer has a default or a
 * limit (renderer/gi/ddgi.h, renderer/view.h), the row names the renderer's constant. Adding a
 * setting is one row here (plus its use and its line in openapi.yaml).
 *
 * Zero is a value: a setting holds what it was given (hysteresis 0 means no history); that a
 * patch sets a value is said by its `has` bits, never by a special value. Where 0 has a
 * meaning of its own (probe_counts 0,0,0 = fitted to the scene, probe_spacing 0 = derived)
 * the row's description says so.
 */
#ifndef SRV_SETTINGS_H
#define SRV_SETTINGS_H

#include <cjson/cJSON.h>
#include <stdbool.h>
#include <stdio.h>

#include "renderer/gi/ddgi.h"
#include "renderer/view.h"
#include "shaders/gpu_types.h"

struct srv_api_error;

/* Which part of the daemon a setting changes: the shared scene and probe field, or each
 * viewer's view. */
enum { SRV_SCOPE_WORLD = 1, SRV_SCOPE_VIEW = 2 };

/* Which commands take a setting as a flag: the CLI column names SRV_CLI_<column>. */
enum {
    SRV_CLI_NONE = 0,
    SRV_CLI_SERVE = 1,
    SRV_CLI_RENDER = 2,
    SRV_CLI_EVAL = 4, /* eval sweeps some as lists (cmd_eval.c says which) */
    SRV_CLI_SERVE_RENDER = SRV_CLI_SERVE | SRV_CLI_RENDER,
    SRV_CLI_ALL = SRV_CLI_SERVE | SRV_CLI_RENDER | SRV_CLI_EVAL,
};

/* Value types: the C member, the JSON value and the CLI syntax.
 *   UINT   unsigned          integer                    N
 *   FLOAT  float             number                     X
 *   FLOAT3 float[3]          array of 3 numbers         X,Y,Z
 *   UINT3  unsigned[3]       array of 3 integers        X,Y,Z
 *   ENUM   unsigned (index)  string, one of its names   NAME
 *   BOOL   bool              true or false              (no value) */
typedef enum srv_setting_type {
    SRV_TYPE_UINT = 1,
    SRV_TYPE_FLOAT,
    SRV_TYPE_FLOAT3,
    SRV_TYPE_UINT3,
    SRV_TYPE_ENUM,
    SRV_TYPE_BOOL,
} srv_setting_type;

/* Names of the enumerations, index = value (PC_TONEMAP_*, PC_VIEW_*, PC_GI_* and
 * SRV_GI_PATHTRACE, PC_ENV_*; settings.c checks them). */
#define SRV_TONEMAP_NAMES "aces", "clamp"
#define SRV_VIEW_NAMES "final", "irradiance", "probes"
#define SRV_GI_NAMES "off", "classic", "ddgi", "pathtrace"
#define SRV_SKY_MODE_NAMES "uniform", "gradient", "image"
#define SRV_VISIBILITY_NAMES "all", "probes", "off"
#define SRV_RELOCATION_NAMES "off", "on"
#define SRV_NEAR_FIELD_NAMES "on", "off" /* PC_NEAR_AUTO, PC_NEAR_OFF */
#define SRV_SHADOW_CULL_NAMES "maps", "off" /* PC_SHADOW_CULL_MAPS, PC_SHADOW_CULL_OFF */
/* gi_mode beyond PC_GI_*: reference path tracing, no probes (srv_settings_to_gi maps it to
 * PC_GI_OFF) */
#define SRV_GI_PATHTRACE 3u

/* Sides of an image, in pixels: of the settings width and height, and of any view the daemon
 * opens for a viewer (server/render/views.c). */
#define SRV_SIDE_MIN 16u
#define SRV_SIDE_MAX 4096u

/* The table. X(ID, field, TYPE, "json", "--flag" or NULL, CLI, "ARG", min, max, default, SCOPE,
 *              (enum names) or (NULL), "description")
 * ID names the bit SRV_SET_<ID> (bit = row index: keep the order, append new rows);
 * CLI names the commands that take "--flag" (SRV_CLI_<CLI>; NONE with a NULL flag);
 * min, max and default apply to every component of FLOAT3 and UINT3; ENUM ranges over its
 * names and BOOL over false/true (their min and max columns are unused: 0, 0). The
 * description is the flag's usage line; the default is printed after it from this table. */
/* clang-format off */
#define SRV_SETTINGS(X)                                                                            \
    X(WIDTH, width, UINT, "width", "--width", ALL, "W", SRV_SIDE_MIN, SRV_SIDE_MAX,                \
      RD_VIEW_DEFAULT_WIDTH, VIEW, (NULL), "image width in pixels")                                \
    X(HEIGHT, height, UINT, "height", "--height", ALL, "H", SRV_SIDE_MIN, SRV_SIDE_MAX,            \
      RD_VIEW_DEFAULT_HEIGHT, VIEW, (NULL), "image height in pixels")                              \
    X(MAX_PIXELS, max_pixels, UINT, "max_pixels", NULL, NONE, "N", SRV_SIDE_MIN * SRV_SIDE_MIN,    \
      SRV_SIDE_MAX * SRV_SIDE_MAX, 1920 * 1080, VIEW, (NULL),                                      \
      "cap on width x height; viewer resize requests are scaled down to it")                       \
    X(MAX_FPS, max_fps, UINT, "max_fps", "--max-fps", SERVE, "N", 1, 240, 30, VIEW, (NULL),        \
      "frame rate cap while something changes")                                                    \
    X(QUALITY_INTERACTIVE, quality_interactive, UINT, "quality_interactive",                       \
      "--quality-interactive", SERVE, "Q", 1, 100, 60, VIEW, (NULL),                               \
      "JPEG quality while input arrives")                                                          \
    X(QUALITY_STILL, quality_still, UINT, "quality_still", "--quality-still", SERVE, "Q", 1, 100,  \
      90, VIEW, (NULL), "JPEG quality of the still frame after input stops")                       \
    X(STILL_DELAY, still_delay_ms, UINT, "still_delay_ms", NULL, NONE, "MS", 0, 10000, 150, VIEW,  \
      (NULL), "quiet time after the last input before the still frame")                            \
    X(EXPOSURE, exposure_ev, FLOAT, "exposure", "--exposure", SERVE_RENDER, "EV", -20, 20, 0,      \
      VIEW, (NULL), "exposure in stops before tone mapping")                                       \
    X(TONEMAP, tonemap, ENUM, "tonemap", "--tonemap", RENDER, "", 0, 0, PC_TONEMAP_ACES, VIEW,     \
      (SRV_TONEMAP_NAMES), "tone curve")                                                           \
    X(SKY, sky, FLOAT3, "sky", "--sky", SERVE_RENDER, "R,G,B", 0, 1000000, 0, WORLD, (NULL),       \
      "radiance of rays that leave the scene")                                                     \
    X(VIEW, view, ENUM, "view", "--view", RENDER, "", 0, 0, PC_VIEW_FINAL, VIEW, (SRV_VIEW_NAMES), \
      "debug views: indirect irradiance only, or probe spheres (need gi classic or ddgi)")         \
    X(GI_MODE, gi_mode, ENUM, "gi_mode", "--gi", SERVE_RENDER, "", 0, 0, PC_GI_DDGI, WORLD,        \
      (SRV_GI_NAMES),                                                                              \
      "global illumination: classic = irradiance probes without visibility (the paper's "        \
      "baseline); pathtrace = the unbiased reference path tracer (serve accumulates its samples " \
      "while nothing changes)")                                                                    \
    X(PROBE_COUNTS, probe_counts, UINT3, "probe_counts", "--probes", ALL, "X,Y,Z", 0,              \
      RD_DDGI_MAX_AXIS_PROBES, 0, WORLD, (NULL), "probes per axis; 0,0,0 = fitted to the scene")  \
    X(PROBE_SPACING, probe_spacing, FLOAT, "probe_spacing", "--probe-spacing", SERVE_RENDER, "S",  \
      0, 1000000, 0, WORLD, (NULL), "probe spacing in metres; 0 = derived from the scene's size")  \
    X(RAYS, rays_per_probe, UINT, "rays_per_probe", "--rays", ALL, "N", 1, PC_DDGI_MAX_RAYS,       \
      RD_DDGI_DEFAULT_RAYS, WORLD, (NULL), "rays per probe per update")                            \
    X(HYSTERESIS, hysteresis, FLOAT, "hysteresis", "--hysteresis", ALL, "H", 0,                    \
      RD_DDGI_MAX_HYSTERESIS, RD_DDGI_DEFAULT_HYSTERESIS, WORLD, (NULL),                           \
      "maximum weight of a probe's old value in its blend (each probe ramps up to it as it "      \
      "settles); 0 keeps no history")                                                              \
    X(ANIMATE, animate, BOOL, "animate", NULL, NONE, "", 0, 0, false, WORLD, (NULL),               \
      "circle the first light slowly while viewers watch (the demo)")                              \
    X(SKY_MODE, sky_mode, ENUM, "sky_mode", "--sky-mode", SERVE, "", 0, 0, PC_ENV_UNIFORM, WORLD,  \
      (SRV_SKY_MODE_NAMES),                                                                        \
      "environment: sky everywhere, a gradient from sky_ground (nadir) to sky (zenith), or the "  \
      "HDR image of PUT /v1/environment (sky where there is none)")                               \
    X(SKY_GROUND, sky_ground, FLOAT3, "sky_ground", "--sky-ground", SERVE, "R,G,B", 0, 1000000, 0, \
      WORLD, (NULL), "radiance toward the nadir (gradient)")                                       \
    X(SKY_INTENSITY, sky_intensity, FLOAT, "sky_intensity", "--sky-intensity", SERVE, "X", 0,      \
      1000000, 1, WORLD, (NULL), "scale of the HDR image's radiance")                              \
    X(SKY_ROTATION, sky_rotation, FLOAT, "sky_rotation", "--sky-rotation", SERVE, "DEG", -360,     \
      360, 0, WORLD, (NULL), "turn of the HDR image about the vertical axis, degrees")             \
    X(VISIBILITY_RAYS, visibility_rays, ENUM, "visibility_rays", "--visibility-rays", ALL, "", 0,  \
      0, PC_DDGI_VIS_ALL, WORLD, (SRV_VISIBILITY_NAMES),                                           \
      "probe visibility rays where geometry crosses a probe cell (walls thinner than the "        \
      "spacing): at probe-ray hits and camera pixels, at probe-ray hits only (no cost per "       \
      "frame), or none (the paper's Chebyshev test alone)")                                      \
    X(PROBE_RELOCATION, probe_relocation, ENUM, "probe_relocation", "--probe-relocation", ALL,    \
      "", 0, 0, 0, WORLD, (SRV_RELOCATION_NAMES),                                                  \
      "on: probes inside geometry move out through its nearest face, and probes on a surface "   \
      "move off it, during their first updates (the 2021 paper's relocation); off: they stay on " \
      "the grid")                                                                                  \
    X(PROBE_PATHS, probe_paths, UINT, "probe_paths", "--probe-paths", ALL, "N", 0,                 \
      RD_DDGI_MAX_PATH_BOUNCES, RD_DDGI_DEFAULT_PATH_BOUNCES, WORLD, (NULL),                       \
      "bounces each probe ray's hit follows (sampling its BRDF, direct light at every vertex) "   \
      "before the probe field ends it, with irradiance blended linearly; 0 = the paper's first " \
      "hit. 3 brings builtin:interior's lamp-lit rooms from -26% to about -7% against the path " \
      "tracer, at 2-4x the probe shading while probes are awake")                                 \
    X(NEAR_FIELD, near_field, ENUM, "near_field", "--near-field", ALL, "", 0, 0, PC_NEAR_AUTO,     \
      VIEW, (SRV_NEAR_FIELD_NAMES),                                                                \
      "near-field rays: camera pixels trace short rays (half a probe spacing) that correct the "  \
      "probe field where light changes faster than its spacing (corners, contacts, lamp "        \
      "shades), one pixel in four per frame, averaged while the view rests; off: the field "     \
      "alone")                                                                                     \
    X(SHADOW_CULL, shadow_cull, ENUM, "shadow_cull", "--shadow-cull", ALL, "", 0, 0,              \
      PC_SHADOW_CULL_MAPS, VIEW, (SRV_SHADOW_CULL_NAMES),                                          \
      "shadow rays of camera pixels and reflections: none toward lights whose distance maps "    \
      "show the point hidden, and at reflection hits the maps' answer where their texels agree " \
      "(maps), or one to every light in front of it (off: exact also behind openings narrower "  \
      "than a map texel)")
/* clang-format on */

/* Values a CPU device (lavapipe) starts with for the settings the command line did not give:
 * X(ID, value). */
#define SRV_SETTINGS_CPU(X)                                                                        \
    X(WIDTH, 512) X(HEIGHT, 288) X(MAX_FPS, 15) X(RAYS, 64) X(PROBE_PATHS, 0)                      \
        X(NEAR_FIELD, PC_NEAR_OFF)

/* ---- generated ------------------------------------------------------------------------------ */

#define SRV_SETTING_CTYPE_UINT unsigned
#define SRV_SETTING_CTYPE_FLOAT float
#define SRV_SETTING_CTYPE_FLOAT3 float
#define SRV_SETTING_CTYPE_UINT3 unsigned
#define SRV_SETTING_CTYPE_ENUM unsigned
#define SRV_SETTING_CTYPE_BOOL bool
#define SRV_SETTING_DIM_UINT
#define SRV_SETTING_DIM_FLOAT
#define SRV_SETTING_DIM_FLOAT3 [3]
#define SRV_SETTING_DIM_UINT3 [3]
#define SRV_SETTING_DIM_ENUM
#define SRV_SETTING_DIM_BOOL

#define SRV_SETTING_MEMBER_(ID, field, TYPE, ...)                                                  \
    SRV_SETTING_CTYPE_##TYPE field SRV_SETTING_DIM_##TYPE;
typedef struct srv_settings {
    SRV_SETTINGS(SRV_SETTING_MEMBER_)
} srv_settings;

#define SRV_SETTING_INDEX_(ID, ...) SRV_SETTING_INDEX_##ID,
enum { SRV_SETTINGS(SRV_SETTING_INDEX_) SRV_SETTING_COUNT };

#define SRV_SETTING_BIT_(ID, ...) SRV_SET_##ID = 1u << SRV_SETTING_INDEX_##ID,
enum { SRV_SETTINGS(SRV_SETTING_BIT_) };

/* The settings whose change restarts the probe field. */
#define SRV_SET_GI_FIELDS                                                                          \
    (SRV_SET_GI_MODE | SRV_SET_PROBE_COUNTS | SRV_SET_PROBE_SPACING | SRV_SET_RAYS |               \
     SRV_SET_HYSTERESIS | SRV_SET_VISIBILITY_RAYS | SRV_SET_PROBE_RELOCATION | SRV_SET_PROBE_PATHS)
/* The settings of the environment (a change relights everything). */
#define SRV_SET_ENV_FIELDS                                                                         \
    (SRV_SET_SKY | SRV_SET_SKY_MODE | SRV_SET_SKY_GROUND | SRV_SET_SKY_INTENSITY |                 \
     SRV_SET_SKY_ROTATION)

typedef struct srv_settings_patch {
    unsigned has;   /* SRV_SET_* */
    srv_settings v; /* the fields named in has */
} srv_settings_patch;

/* One row of the table as data. */
typedef struct srv_setting_info {
    unsigned bit;      /* SRV_SET_* */
    const char *field; /* member of srv_settings */
    size_t offset;     /* offsetof(srv_settings, field) */
    srv_setting_type type;
    const char *json;         /* API name */
    const char *flag;         /* command-line flag, or NULL */
    unsigned cli;             /* SRV_CLI_*: the commands that take the flag */
    const char *arg;          /* the flag's value in the usage text */
    double min, max, def;     /* per component */
    int scope;                /* SRV_SCOPE_* */
    const char *const *names; /* ENUM: names[value] */
    unsigned name_count;
    const char *desc;
} srv_setting_info;

/* Row i (0 <= i < SRV_SETTING_COUNT) of the table. */
const srv_setting_info *srv_setting_at(unsigned i);
/* The row of an API name, or NULL. */
const srv_setting_info *srv_setting_by_json(const char *json);
/* The row of a flag that command cli (SRV_CLI_SERVE, _RENDER or _EVAL) takes, or NULL. */
const srv_setting_info *srv_setting_by_flag(const char *flag, unsigned cli);

/* ---- values ----------------------------------------------------------------------------- */

/* Every setting at its default. */
void srv_settings_defaults(srv_settings *s);
/* The SRV_SET_* bits of the settings of scope SRV_SCOPE_WORLD or SRV_SCOPE_VIEW. */
unsigned srv_settings_scope_mask(int scope);
/* Sets the SRV_SETTINGS_CPU values of the settings not in `given` (SRV_SET_* bits). */
void srv_settings_adapt_to_cpu(srv_settings *s, unsigned given);
/* The API name of a gi_mode value ("unknown" beyond them). */
const char *srv_gi_mode_name(unsigned mode);

/* Applies the fields p->has names to *s, all or nothing: each value must be in its range, and
 * the result must hold together (width x height <= max_pixels, the irradiance and probes views
 * need gi_mode classic or ddgi, at most RD_DDGI_MAX_PROBES probes). Else *s is untouched and e
 * says why (400 invalid_field). */
bool srv_state_settings_apply(srv_settings *s, const srv_settings_patch *p,
                              struct srv_api_error *e);
/* The renderer's GI settings for s, for the daemon and `probecast render` alike: gi_mode
 * pathtrace becomes PC_GI_OFF (the path tracer needs no probes), every value is passed as set
 * (hysteresis 0 stays 0: no history), seed 0. */
void srv_settings_to_gi(const srv_settings *s, rd_ddgi_settings *gi);

/* ---- JSON (protocol/openapi.yaml, Settings) --------------------------------------------- */

/* A settings patch from a JSON object: every member must be a known setting, given once, of
 * its type and in its range; else false with a 400 srv_api_error naming the member. */
bool srv_json_settings_patch(const cJSON *obj, srv_settings_patch *out, struct srv_api_error *e);
/* All settings as a new JSON object (the caller owns it). */
cJSON *srv_json_settings(const srv_settings *s);

/* ---- command line ------------------------------------------------------------------------ */

/* When argv[*i] is a setting's flag that command cli (SRV_CLI_*) takes, reads its value
 * (argv[*i + 1], advancing *i) into *s and adds the setting's bit to *given: returns 1. Returns
 * 0 when argv[*i] is no such flag, and -1 after printing one message to stderr (prefixed with
 * cmd, e.g. "probecast serve") when the value is missing or not valid. */
int srv_settings_parse_flag(const char *cmd, unsigned cli, int argc, char **argv, int *i,
                            srv_settings *s, unsigned *given);
/* Reads text as one value of d (the syntax of its type above) into d's member of *s: true, or
 * false after one message on stderr ("CMD: --flag expects ..., got 'TEXT'"); *s is then
 * untouched. */
bool srv_setting_parse(const char *cmd, const srv_setting_info *d, const char *text,
                       srv_settings *s);
/* A list of values of d, as eval sweeps them: separated by ',' ("64,128"), or by ';' where a
 * value has 3 components ("2,2,2;4,4,4"); each read as srv_setting_parse reads one, into d's
 * member of out[k]. *n = how many. False after one message when one is not valid, or when there
 * are none or more than max. */
bool srv_setting_parse_list(const char *cmd, const srv_setting_info *d, const char *text,
                            srv_settings *out, unsigned max, unsigned *n);
/* Prints the usage lines of the setting flags of command cli with the table's defaults (and, for
 * serve, the CPU defaults). */
void srv_settings_print_usage(FILE *f, unsigned cli);
/* Prints d's usage line: "--flag ARG" ("ARG[,ARG...]" for a list), the description and
 * "(default DEF)"; def NULL = the table's default. */
void srv_setting_print_usage(FILE *f, const srv_setting_info *d, bool list, const char *def);

#endif
