/* The settings table (server/api/settings.h) and what is generated from it: defaults, JSON in and
 * out, range checks, scopes; and protocol/openapi.yaml's Settings schema against the table. The
 * command line made from it is checked by test_settings_cli.c. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "server/api/api_json.h"
#include "server/api/settings.h"
#include "test_util.h"

#define ALL_BITS ((1u << SRV_SETTING_COUNT) - 1)

static int dims(const srv_setting_info *d)
{
    return d->type == SRV_TYPE_FLOAT3 || d->type == SRV_TYPE_UINT3 ? 3 : 1;
}

static bool parse(const char *text, srv_settings_patch *p, srv_api_error *e)
{
    cJSON *j = srv_json_parse_object(text, strlen(text), e);
    if (!j) return false;
    bool ok = srv_json_settings_patch(j, p, e);
    cJSON_Delete(j);
    return ok;
}

/* ---- protocol/openapi.yaml, components.schemas.Settings ---------------------------------- */

typedef struct yprop {
    char name[64];
    /* each as the YAML has it (a line holds at most 256 characters) */
    char type[256], items_type[256], min[256], max[256], items_min[256], items_max[256];
    char min_items[256], max_items[256], def[256], enums[256];
} yprop;

/* Line-oriented: the Settings schema's properties at indent 8, their keys at 10, the keys of
 * their items at 12; block scalars (description: |) are skipped. */
static int read_schema(const char *path, yprop *props, int max)
{
    FILE *f = fopen(path, "r");
    if (!f) return -1;
    char line[512];
    int n = 0, state = 0, block = -1; /* state: 0 before, 1 in Settings, 2 in its properties */
    bool in_items = false;
    while (fgets(line, sizeof line, f)) {
        line[strcspn(line, "\r\n")] = 0;
        int ind = (int)strspn(line, " ");
        const char *t = line + ind;
        if (!*t || *t == '#') continue;
        if (block >= 0 && ind > block) continue;
        block = -1;
        if (state == 0) {
            if (ind == 4 && strcmp(t, "Settings:") == 0) state = 1;
            continue;
        }
        if (ind <= 4) break; /* the next schema */
        const char *colon = strchr(t, ':');
        if (!colon) continue;
        char key[64], val[256];
        snprintf(key, sizeof key, "%.*s", (int)(colon - t), t);
        snprintf(val, sizeof val, "%s", colon[1] == ' ' ? colon + 2 : colon + 1);
        if (strcmp(val, "|") == 0 || strcmp(val, ">") == 0) block = ind;
        if (ind == 6) {
            state = strcmp(key, "properties") == 0 ? 2 : 1;
        } else if (state == 2 && ind == 8 && n < max) {
            memset(&props[n], 0, sizeof props[n]);
            snprintf(props[n++].name, sizeof props[0].name, "%s", key);
            in_items = false;
        } else if (state == 2 && ind == 10 && n > 0) {
            yprop *p = &props[n - 1];
            in_items = strcmp(key, "items") == 0;
            if (strcmp(key, "type") == 0) snprintf(p->type, sizeof p->type, "%s", val);
            if (strcmp(key, "minimum") == 0) snprintf(p->min, sizeof p->min, "%s", val);
            if (strcmp(key, "maximum") == 0) snprintf(p->max, sizeof p->max, "%s", val);
            if (strcmp(key, "default") == 0) snprintf(p->def, sizeof p->def, "%s", val);
            if (strcmp(key, "enum") == 0) snprintf(p->enums, sizeof p->enums, "%s", val);
            if (strcmp(key, "minItems") == 0)
                snprintf(p->min_items, sizeof p->min_items, "%s", val);
            if (strcmp(key, "maxItems") == 0)
                snprintf(p->max_items, sizeof p->max_items, "%s", val);
        } else if (state == 2 && ind == 12 && n > 0 && in_items) {
            yprop *p = &props[n - 1];
            if (strcmp(key, "type") == 0) snprintf(p->items_type, sizeof p->items_type, "%s", val);
            if (strcmp(key, "minimum") == 0) snprintf(p->items_min, sizeof p->items_min, "%s", val);
            if (strcmp(key, "maximum") == 0) snprintf(p->items_max, sizeof p->items_max, "%s", val);
        }
    }
    fclose(f);
    return n;
}

/* A YAML number equals the table's (float settings compared as floats). */
static bool same_number(const char *yaml, double want, bool is_float)
{
    char *end = NULL;
    double v = strtod(yaml, &end);
    if (!*yaml || *end) return false;
    return is_float ? (float)v == (float)want : v == want;
}

/* 'x' or "x" to x, in place. */
static void unquote(char *s)
{
    size_t n = strlen(s);
    if (n >= 2 && (s[0] == '\'' || s[0] == '"') && s[n - 1] == s[0]) {
        memmove(s, s + 1, n - 2);
        s[n - 2] = 0;
    }
}

/* "[a, 'b', c]" split into items without quotes; returns the count. */
static int split_list(const char *s, char items[][32], int max)
{
    int n = 0;
    if (*s != '[') return -1;
    s++;
    while (*s && *s != ']' && n < max) {
        while (*s == ' ')
            s++;
        size_t len = strcspn(s, ",]");
        char *it = items[n++];
        snprintf(it, 32, "%.*s", (int)len, s);
        for (size_t k = strlen(it); k > 0 && it[k - 1] == ' '; k--)
            it[k - 1] = 0;
        unquote(it);
        s += len;
        if (*s == ',') s++;
    }
    return n;
}

static void check_property(const srv_setting_info *d, const yprop *p)
{
    bool fl = d->type == SRV_TYPE_FLOAT || d->type == SRV_TYPE_FLOAT3;
    const char *scalar = fl ? "number" : "integer";
    switch (d->type) {
    case SRV_TYPE_UINT:
    case SRV_TYPE_FLOAT:
        CHECKF(strcmp(p->type, scalar) == 0, "%s: type %s", d->json, p->type);
        CHECKF(same_number(p->min, d->min, fl), "%s: minimum '%s', table %g", d->json, p->min,
               d->min);
        CHECKF(same_number(p->max, d->max, fl), "%s: maximum '%s', table %g", d->json, p->max,
               d->max);
        CHECKF(same_number(p->def, d->def, fl), "%s: default '%s', table %g", d->json, p->def,
               d->def);
        break;
    case SRV_TYPE_FLOAT3:
    case SRV_TYPE_UINT3: {
        CHECKF(strcmp(p->type, "array") == 0, "%s: type %s", d->json, p->type);
        CHECKF(strcmp(p->min_items, "3") == 0 && strcmp(p->max_items, "3") == 0,
               "%s: minItems/maxItems '%s'/'%s'", d->json, p->min_items, p->max_items);
        CHECKF(strcmp(p->items_type, scalar) == 0, "%s: items type %s", d->json, p->items_type);
        CHECKF(same_number(p->items_min, d->min, fl), "%s: items minimum '%s', table %g", d->json,
               p->items_min, d->min);
        CHECKF(same_number(p->items_max, d->max, fl), "%s: items maximum '%s', table %g", d->json,
               p->items_max, d->max);
        char items[8][32];
        int n = split_list(p->def, items, 8);
        CHECKF(n == 3, "%s: default '%s' is not 3 items", d->json, p->def);
        for (int i = 0; i < n && i < 3; i++)
            CHECKF(same_number(items[i], d->def, fl), "%s: default '%s', table %g", d->json, p->def,
                   d->def);
        break;
    }
    case SRV_TYPE_ENUM: {
        CHECKF(strcmp(p->type, "string") == 0, "%s: type %s", d->json, p->type);
        char items[16][32];
        int n = split_list(p->enums, items, 16);
        CHECKF(n == (int)d->name_count, "%s: enum '%s' has %d names, the table %u", d->json,
               p->enums, n, d->name_count);
        for (int i = 0; i < n && i < (int)d->name_count; i++)
            CHECKF(strcmp(items[i], d->names[i]) == 0, "%s: enum name %d is '%s', table '%s'",
                   d->json, i, items[i], d->names[i]);
        char def[256];
        snprintf(def, sizeof def, "%s", p->def);
        unquote(def);
        CHECKF(strcmp(def, d->names[(unsigned)d->def]) == 0, "%s: default '%s', table '%s'",
               d->json, def, d->names[(unsigned)d->def]);
        break;
    }
    case SRV_TYPE_BOOL:
        CHECKF(strcmp(p->type, "boolean") == 0, "%s: type %s", d->json, p->type);
        CHECKF(strcmp(p->def, d->def != 0 ? "true" : "false") == 0, "%s: default '%s'", d->json,
               p->def);
        break;
    }
}

static void test_openapi(void)
{
    static yprop props[64];
    int n = read_schema(PROBECAST_SOURCE_DIR "/protocol/openapi.yaml", props, 64);
    CHECKF(n > 0, "no Settings properties read from openapi.yaml (%d)", n);
    bool seen[SRV_SETTING_COUNT] = {false};
    for (int i = 0; i < n; i++) {
        const srv_setting_info *d = srv_setting_by_json(props[i].name);
        CHECKF(d != NULL, "openapi.yaml has setting '%s' that the table lacks", props[i].name);
        if (!d) continue;
        unsigned idx = (unsigned)(d - srv_setting_at(0));
        CHECKF(!seen[idx], "openapi.yaml lists '%s' twice", d->json);
        seen[idx] = true;
        check_property(d, &props[i]);
    }
    for (unsigned i = 0; i < SRV_SETTING_COUNT; i++)
        CHECKF(seen[i], "openapi.yaml lacks setting '%s'", srv_setting_at(i)->json);
}

/* ---- the table itself --------------------------------------------------------------------- */

static void test_table(void)
{
    unsigned bits = 0;
    for (unsigned i = 0; i < SRV_SETTING_COUNT; i++) {
        const srv_setting_info *d = srv_setting_at(i);
        CHECKF(d->bit == 1u << i, "%s: bit", d->json);
        CHECKF(srv_setting_by_json(d->json) == d, "%s: found by name", d->json);
        CHECKF(d->min <= d->def && d->def <= d->max, "%s: default %g outside [%g, %g]", d->json,
               d->def, d->min, d->max);
        CHECKF(d->desc && d->desc[0], "%s: description", d->json);
        CHECKF(d->type != SRV_TYPE_ENUM || d->name_count > 1, "%s: names", d->json);
        bits |= d->bit;
    }
    CHECK(bits == ALL_BITS && srv_setting_at(SRV_SETTING_COUNT) == NULL);
    /* the bit values other code was written against */
    CHECK(SRV_SET_WIDTH == 1u << 0 && SRV_SET_STILL_DELAY == 1u << 6 && SRV_SET_RAYS == 1u << 14 &&
          SRV_SET_ANIMATE == 1u << 16);

    unsigned world = srv_settings_scope_mask(SRV_SCOPE_WORLD);
    unsigned view = srv_settings_scope_mask(SRV_SCOPE_VIEW);
    CHECK((world | view) == ALL_BITS && (world & view) == 0);
    CHECK((world & SRV_SET_GI_FIELDS) == SRV_SET_GI_FIELDS);
    CHECK(world == (SRV_SET_ENV_FIELDS | SRV_SET_GI_FIELDS | SRV_SET_ANIMATE));
    CHECK(view & SRV_SET_WIDTH && view & SRV_SET_EXPOSURE && view & SRV_SET_VIEW);
    CHECK(srv_settings_scope_mask(0) == 0);

    /* the ranges and defaults the renderer defines, taken by name */
    const srv_setting_info *h = srv_setting_at(SRV_SETTING_INDEX_HYSTERESIS);
    CHECK(h->min == 0 && h->max == RD_DDGI_MAX_HYSTERESIS && h->def == RD_DDGI_DEFAULT_HYSTERESIS);
    const srv_setting_info *r = srv_setting_at(SRV_SETTING_INDEX_RAYS);
    CHECK(r->max == PC_DDGI_MAX_RAYS && r->def == RD_DDGI_DEFAULT_RAYS);
    CHECK(srv_setting_at(SRV_SETTING_INDEX_PROBE_COUNTS)->max == RD_DDGI_MAX_AXIS_PROBES);
    CHECK(srv_setting_at(SRV_SETTING_INDEX_WIDTH)->def == RD_VIEW_DEFAULT_WIDTH);
    CHECK(srv_setting_at(SRV_SETTING_INDEX_HEIGHT)->def == RD_VIEW_DEFAULT_HEIGHT);

    /* a flag for the commands that take it, each flag once */
    for (unsigned i = 0; i < SRV_SETTING_COUNT; i++) {
        const srv_setting_info *d = srv_setting_at(i);
        CHECKF(!d->flag == !d->cli && (d->cli & ~(unsigned)SRV_CLI_ALL) == 0, "%s: flag and CLI",
               d->json);
        CHECKF(!d->flag || srv_setting_by_flag(d->flag, d->cli) == d, "%s: found by flag", d->json);
        CHECKF(!d->flag || srv_setting_by_flag(d->flag, SRV_CLI_ALL & ~d->cli) == NULL,
               "%s: only its commands take %s", d->json, d->flag);
    }

    CHECK(strcmp(srv_gi_mode_name(PC_GI_DDGI), "ddgi") == 0);
    CHECK(strcmp(srv_gi_mode_name(SRV_GI_PATHTRACE), "pathtrace") == 0);
    CHECK(strcmp(srv_gi_mode_name(99), "unknown") == 0);
}

static void test_defaults(void)
{
    srv_settings s;
    srv_settings_defaults(&s);
    CHECK(s.width == 960 && s.height == 540 && s.max_pixels == 1920 * 1080 && s.max_fps == 30);
    CHECK(s.quality_interactive == 60 && s.quality_still == 90 && s.still_delay_ms == 150);
    CHECK(s.exposure_ev == 0 && s.tonemap == PC_TONEMAP_ACES && s.view == PC_VIEW_FINAL);
    CHECK(s.sky[0] == 0 && s.sky[1] == 0 && s.sky[2] == 0);
    CHECK(s.gi_mode == PC_GI_DDGI && s.probe_counts[0] == 0 && s.probe_counts[2] == 0);
    CHECK(s.probe_spacing == 0 && !s.animate);
    CHECK(s.rays_per_probe == RD_DDGI_DEFAULT_RAYS);
    CHECK(s.hysteresis == RD_DDGI_DEFAULT_HYSTERESIS);

    /* the defaults are a valid patch */
    srv_settings t;
    srv_settings_defaults(&t);
    srv_settings_patch p = {.has = ALL_BITS, .v = s};
    srv_api_error e;
    CHECK(srv_state_settings_apply(&t, &p, &e));

    /* every default as the JSON view gives it */
    cJSON *j = srv_json_settings(&s);
    for (unsigned i = 0; i < SRV_SETTING_COUNT; i++) {
        const srv_setting_info *d = srv_setting_at(i);
        const cJSON *it = cJSON_GetObjectItemCaseSensitive(j, d->json);
        CHECKF(it != NULL, "%s in the JSON view", d->json);
        if (!it) continue;
        if (d->type == SRV_TYPE_ENUM)
            CHECKF(cJSON_IsString(it) && strcmp(it->valuestring, d->names[(unsigned)d->def]) == 0,
                   "%s", d->json);
        else if (d->type == SRV_TYPE_BOOL)
            CHECKF(cJSON_IsBool(it) && cJSON_IsTrue(it) == (d->def != 0), "%s", d->json);
        else if (dims(d) == 3)
            CHECKF(cJSON_IsArray(it) && cJSON_GetArraySize(it) == 3 &&
                       cJSON_GetArrayItem(it, 1)->valuedouble == d->def,
                   "%s", d->json);
        else
            CHECKF(cJSON_IsNumber(it) && (float)it->valuedouble == (float)d->def, "%s = %g",
                   d->json, it->valuedouble);
    }
    CHECK(cJSON_GetArraySize(j) == SRV_SETTING_COUNT);
    cJSON_Delete(j);

    /* a CPU device starts smaller where the command line did not choose */
    srv_settings c = s;
    srv_settings_adapt_to_cpu(&c, SRV_SET_WIDTH | SRV_SET_RAYS);
    CHECK(c.width == 960 && c.height == 288 && c.rays_per_probe == RD_DDGI_DEFAULT_RAYS &&
          c.max_fps == 15 && c.quality_still == 90);
}

/* ---- JSON in and out -------------------------------------------------------------------- */

static void test_round_trip(void)
{
    srv_settings s;
    srv_settings_defaults(&s);
    s.width = 640, s.height = 360, s.max_pixels = 1 << 20, s.max_fps = 12;
    s.quality_interactive = 33, s.quality_still = 99, s.still_delay_ms = 0;
    s.exposure_ev = -1.5f, s.tonemap = PC_TONEMAP_CLAMP;
    s.sky[0] = 0.25f, s.sky[1] = 0.5f, s.sky[2] = 1000;
    s.view = PC_VIEW_PROBES, s.gi_mode = PC_GI_CLASSIC;
    s.probe_counts[0] = 4, s.probe_counts[1] = 5, s.probe_counts[2] = 6;
    s.probe_spacing = 0.7f, s.rays_per_probe = 1024, s.hysteresis = 0.999f, s.animate = true;

    char *text = srv_json_print_delete(srv_json_settings(&s));
    srv_settings_patch p;
    srv_api_error e;
    CHECKF(parse(text, &p, &e), "%s: %s", text, e.message);
    CHECK(p.has == ALL_BITS);
    srv_settings t;
    srv_settings_defaults(&t);
    CHECKF(srv_state_settings_apply(&t, &p, &e), "%s", e.message);
    char *text2 = srv_json_print_delete(srv_json_settings(&t));
    CHECKF(strcmp(text, text2) == 0, "%s\n  became %s", text, text2);
    CHECK(t.width == 640 && t.max_pixels == 1 << 20 && t.still_delay_ms == 0);
    CHECK(t.exposure_ev == -1.5f && t.tonemap == PC_TONEMAP_CLAMP && t.sky[2] == 1000);
    CHECK(t.view == PC_VIEW_PROBES && t.gi_mode == PC_GI_CLASSIC && t.probe_counts[2] == 6);
    CHECK(t.probe_spacing == 0.7f && t.rays_per_probe == 1024 && t.hysteresis == 0.999f);
    CHECK(t.animate);
    free(text);
    free(text2);

    /* a partial patch names only what it sets */
    CHECK(parse("{\"gi_mode\":\"pathtrace\",\"sky\":[1,2,3]}", &p, &e));
    CHECK(p.has == (SRV_SET_GI_MODE | SRV_SET_SKY) && p.v.gi_mode == SRV_GI_PATHTRACE &&
          p.v.sky[1] == 2);
    CHECK(parse("{}", &p, &e) && p.has == 0);
}

/* hysteresis 0 is a value (no history), not "the default". */
static void test_zero_is_a_value(void)
{
    srv_settings s;
    srv_settings_defaults(&s);
    srv_settings_patch p;
    srv_api_error e;
    CHECK(parse("{\"hysteresis\":0,\"exposure\":0}", &p, &e) &&
          p.has == (SRV_SET_HYSTERESIS | SRV_SET_EXPOSURE));
    CHECK(srv_state_settings_apply(&s, &p, &e) && s.hysteresis == 0);
    rd_ddgi_settings gi;
    srv_settings_to_gi(&s, &gi);
    CHECK(gi.hysteresis == 0 && gi.has_hysteresis && gi.rays == RD_DDGI_DEFAULT_RAYS);
    cJSON *j = srv_json_settings(&s);
    const cJSON *h = cJSON_GetObjectItemCaseSensitive(j, "hysteresis");
    CHECK(cJSON_IsNumber(h) && h->valuedouble == 0);
    cJSON_Delete(j);

    srv_settings_defaults(&s);
    srv_settings_to_gi(&s, &gi);
    CHECK(gi.hysteresis == RD_DDGI_DEFAULT_HYSTERESIS && gi.mode == PC_GI_DDGI);
    s.gi_mode = SRV_GI_PATHTRACE;
    srv_settings_to_gi(&s, &gi);
    CHECK(gi.mode == PC_GI_OFF); /* the path tracer uses no probes */
}

/* A JSON body with d just outside its range (an unknown name, a wrong kind of value). */
static void bad_json(const srv_setting_info *d, bool above, char *buf, size_t len)
{
    bool fl = d->type == SRV_TYPE_FLOAT || d->type == SRV_TYPE_FLOAT3;
    double bound = above ? d->max : d->min;
    double eps = fl ? 1e-3 * (1 + fabs(bound)) : 1; /* still beyond it as a float */
    double x = above ? bound + eps : bound - eps;
    switch (d->type) {
    case SRV_TYPE_ENUM:
        snprintf(buf, len, "{\"%s\":\"%s\"}", d->json, above ? "nope" : "");
        break;
    case SRV_TYPE_BOOL:
        snprintf(buf, len, "{\"%s\":%s}", d->json, above ? "1" : "\"true\"");
        break;
    case SRV_TYPE_FLOAT3:
    case SRV_TYPE_UINT3:
        snprintf(buf, len, "{\"%s\":[%.17g,%.17g,%.17g]}", d->json, d->def ? d->def : 1, x,
                 d->def ? d->def : 1);
        break;
    default:
        snprintf(buf, len, "{\"%s\":%.17g}", d->json, x);
    }
}

static void test_rejects(void)
{
    srv_settings_patch p;
    srv_api_error e;
    char body[256];
    for (unsigned i = 0; i < SRV_SETTING_COUNT; i++) {
        const srv_setting_info *d = srv_setting_at(i);
        for (int above = 0; above < 2; above++) {
            bad_json(d, above, body, sizeof body);
            e.status = 0;
            bool ok = parse(body, &p, &e);
            CHECKF(!ok && e.status == 400 && strcmp(e.code, SRV_ERR_INVALID_FIELD) == 0 &&
                       strstr(e.message, d->json),
                   "%s accepted or wrong error: %s", body, e.message);
        }
        /* the wrong JSON type */
        snprintf(body, sizeof body, "{\"%s\":%s}", d->json,
                 d->type == SRV_TYPE_ENUM ? "0" : "\"x\"");
        CHECKF(!parse(body, &p, &e) && strstr(e.message, d->json), "%s", body);
        /* a whole number is required where the setting is one */
        if (d->type == SRV_TYPE_UINT) {
            snprintf(body, sizeof body, "{\"%s\":%g}", d->json, d->min + 0.5);
            CHECKF(!parse(body, &p, &e), "%s", body);
        }
        /* given twice */
        srv_settings s;
        srv_settings_defaults(&s);
        cJSON *j = srv_json_settings(&s), *one = cJSON_CreateObject();
        cJSON_AddItemToObject(one, d->json, cJSON_Duplicate(cJSON_GetObjectItem(j, d->json), true));
        cJSON_AddItemToObject(one, d->json, cJSON_Duplicate(cJSON_GetObjectItem(j, d->json), true));
        CHECKF(!srv_json_settings_patch(one, &p, &e) && strstr(e.message, "more than once"),
               "%s twice", d->json);
        cJSON_Delete(one);
        cJSON_Delete(j);

        /* apply checks ranges too (patches built in C), all or nothing */
        if (d->type == SRV_TYPE_BOOL) continue;
        srv_settings before = s;
        srv_settings_patch bad = {.has = d->bit, .v = s};
        char *at = (char *)&bad.v + d->offset;
        for (int k = 0; k < dims(d); k++) {
            if (d->type == SRV_TYPE_FLOAT || d->type == SRV_TYPE_FLOAT3)
                ((float *)at)[k] = (float)d->max * 1.01f + 1;
            else
                ((unsigned *)at)[k] = (unsigned)d->max + 1;
        }
        CHECKF(!srv_state_settings_apply(&s, &bad, &e) && strstr(e.message, d->json),
               "apply took %s above its maximum", d->json);
        CHECK(memcmp(&s, &before, sizeof s) == 0);
    }
    CHECK(!parse("{\"wdith\":64}", &p, &e) && strstr(e.message, "wdith"));
    CHECK(!parse("{\"probe_counts\":[0,2,2]}", &p, &e) && strstr(e.message, "probe_counts"));
    CHECK(!parse("{\"probe_counts\":[2,2]}", &p, &e));
    CHECK(!parse("{\"sky\":[1,2,\"3\"]}", &p, &e));
    CHECK(!parse("{\"hysteresis\":1}", &p, &e));
    CHECK(parse("{\"hysteresis\":0.999,\"still_delay_ms\":0,\"exposure\":-20}", &p, &e));
    CHECK(parse("{\"probe_counts\":[0,0,0],\"probe_spacing\":0}", &p, &e));

    /* rules between settings */
    srv_settings s;
    srv_settings_defaults(&s);
    srv_settings_patch big = {.has = SRV_SET_WIDTH | SRV_SET_HEIGHT,
                              .v = {.width = 4096, .height = 4096}};
    CHECK(!srv_state_settings_apply(&s, &big, &e) && s.width == 960);
    srv_settings_patch probes = {.has = SRV_SET_VIEW | SRV_SET_GI_MODE,
                                 .v = {.view = PC_VIEW_PROBES, .gi_mode = PC_GI_OFF}};
    CHECK(!srv_state_settings_apply(&s, &probes, &e) && s.view == PC_VIEW_FINAL);
    srv_settings_patch many = {.has = SRV_SET_PROBE_COUNTS, .v = {.probe_counts = {256, 256, 2}}};
    CHECK(!srv_state_settings_apply(&s, &many, &e) && s.probe_counts[0] == 0);
}

int main(void)
{
    test_table();
    test_defaults();
    test_round_trip();
    test_zero_is_a_value();
    test_rejects();
    test_openapi();
    return test_finish();
}
