/*
 * manoeuvre.h - what the two C hosts share: host.c (FMI 2.0) and host3.c (FMI 3.0).
 *
 * - Loading an FMI function from the FMU's shared library (load_symbol, LOAD).
 * - Reading the FMU's modelDescription.xml from the path of its shared library
 *   (<root>/binaries/<platform>/<id>.so): an attribute of the root element (guid,
 *   instantiationToken) and the value reference of a variable by name, so that a host
 *   needs no value reference beyond those the FMU declares.
 * - The manoeuvres a host sails with "--run NAME", and the CSV it prints of them:
 *   one row per communication point, the inputs held over the step that follows it and
 *   the outputs at it, every number with 17 significant digits (exact as a double).
 *   tests/test_fmu_c_hosts.py compares the two hosts' runs with each other and with
 *   fmu_model.simulate on the same inputs.
 *
 * The manoeuvres start at the FMU's start values (u0 = the nominal speed, at rest
 * otherwise), propeller at RUN_RPM, communication step RUN_STEP_S. The helm moves the
 * rudder toward its command at RUN_RUDDER_RATE_DEG_S (the steering gear, as
 * trials.run does); a zig-zag reverses the command when the heading change since the
 * start passes the check heading, a turn holds it. The current (constant) is set with
 * the first step.
 */
#ifndef SHIP_HOST_MANOEUVRE_H
#define SHIP_HOST_MANOEUVRE_H

#include <dlfcn.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Load symbol `name` of `library` into the function pointer at `function_pointer`. */
static int load_symbol(void *library, const char *name, void *function_pointer, size_t size)
{
    void *symbol = dlsym(library, name);
    if (symbol == NULL) {
        fprintf(stderr, "missing symbol %s\n", name);
        return 0;
    }
    memcpy(function_pointer, &symbol, size); /* object to function pointer, POSIX style */
    return 1;
}

#define LOAD(field, name) ok &= load_symbol(library, name, &api->field, sizeof api->field)

#ifndef PI
#define PI 3.14159265358979323846
#endif

#define RUN_STEP_S 0.1
#define RUN_RPM 120.0
#define RUN_RUDDER_RATE_DEG_S 2.34

typedef struct {
    const char *name;
    double rudder_deg;            /* first rudder command, positive to starboard */
    double check_deg;             /* zig-zag check heading; 0 for a turn */
    double current_speed;         /* current over ground [m/s], constant */
    double current_direction_deg; /* direction it sets towards, clockwise from North */
    double duration_s;
} Manoeuvre;

static const Manoeuvre MANOEUVRES[] = {
    {"turn-35", 35.0, 0.0, 0.0, 0.0, 300.0},
    {"zigzag-10", 10.0, 10.0, 0.0, 0.0, 300.0},
    {"zigzag-10-current", 10.0, 10.0, 0.5, 90.0, 300.0},
};
#define N_MANOEUVRES (sizeof MANOEUVRES / sizeof MANOEUVRES[0])

/* The variables a run sets and prints, by name: inputs, then outputs. */
static const char *const RUN_INPUTS[] = {"rudder_angle", "propeller_rpm", "current_speed",
                                         "current_direction"};
#define N_RUN_INPUTS 4
static const char *const RUN_OUTPUTS[] = {"u", "v", "r", "x", "y", "psi", "sog", "cog"};
#define N_RUN_OUTPUTS 8
#define RUN_PSI 5 /* index of psi in RUN_OUTPUTS */

static const Manoeuvre *find_manoeuvre(const char *name)
{
    size_t i;
    for (i = 0; i < N_MANOEUVRES; i++) {
        if (strcmp(MANOEUVRES[i].name, name) == 0) {
            return &MANOEUVRES[i];
        }
    }
    return NULL;
}

/* The helm of a run: the rudder command and the rudder angle [rad]. */
typedef struct {
    const Manoeuvre *m;
    double command;
    double rudder;
    double heading0;
    int started;
} Helm;

/* The inputs to hold over the next step, from the heading psi [rad] now:
   rudder angle [rad], propeller [rpm], current speed [m/s] and direction [rad]. */
static void helm_next(Helm *helm, double psi, double *inputs)
{
    const double delta = helm->m->rudder_deg * PI / 180.0;
    const double check = helm->m->check_deg * PI / 180.0;
    const double max_move = RUN_RUDDER_RATE_DEG_S * PI / 180.0 * RUN_STEP_S;
    double move;
    if (!helm->started) {
        helm->started = 1;
        helm->heading0 = psi;
        helm->command = delta;
        helm->rudder = 0.0;
    }
    if (check > 0.0) {
        const double change = psi - helm->heading0;
        if (helm->command > 0.0 && change >= check) {
            helm->command = -delta;
        } else if (helm->command < 0.0 && change <= -check) {
            helm->command = delta;
        }
    }
    move = helm->command - helm->rudder;
    move = move > max_move ? max_move : (move < -max_move ? -max_move : move);
    helm->rudder += move;
    inputs[0] = helm->rudder;
    inputs[1] = RUN_RPM;
    inputs[2] = helm->m->current_speed;
    inputs[3] = helm->m->current_direction_deg * PI / 180.0;
}

static void print_header(void)
{
    int i;
    printf("time");
    for (i = 0; i < N_RUN_INPUTS; i++) {
        printf(",%s", RUN_INPUTS[i]);
    }
    for (i = 0; i < N_RUN_OUTPUTS; i++) {
        printf(",%s", RUN_OUTPUTS[i]);
    }
    putchar('\n');
}

static void print_row(double t, const double *inputs, const double *outputs)
{
    int i;
    printf("%.17g", t);
    for (i = 0; i < N_RUN_INPUTS; i++) {
        printf(",%.17g", inputs[i]);
    }
    for (i = 0; i < N_RUN_OUTPUTS; i++) {
        printf(",%.17g", outputs[i]);
    }
    putchar('\n');
}

/* The text of <root>/modelDescription.xml for library_path = <root>/binaries/<p>/<id>.so
   (free() it), and root in root[size]; NULL when it cannot be read. */
static char *read_model_description(const char *library_path, char *root, size_t size)
{
    char path[4096];
    char *text;
    long length;
    int levels = 0;
    size_t n = strlen(library_path);
    FILE *file;
    if (n >= sizeof path || n >= size) {
        return NULL;
    }
    memcpy(path, library_path, n + 1);
    while (n > 0 && levels < 3) { /* strip the file name, the platform and binaries */
        n--;
        if (path[n] == '/') {
            levels++;
            path[n] = '\0';
        }
    }
    if (levels != 3 || n + strlen("/modelDescription.xml") + 1 > sizeof path) {
        return NULL;
    }
    memcpy(root, path, n + 1);
    strcat(path, "/modelDescription.xml");
    file = fopen(path, "rb");
    if (file == NULL) {
        fprintf(stderr, "cannot open %s\n", path);
        return NULL;
    }
    fseek(file, 0, SEEK_END);
    length = ftell(file);
    fseek(file, 0, SEEK_SET);
    text = length < 0 ? NULL : (char *)calloc((size_t)length + 1, 1);
    if (text == NULL || fread(text, 1, (size_t)length, file) != (size_t)length) {
        fclose(file);
        free(text);
        return NULL;
    }
    fclose(file);
    return text;
}

/* The value of attribute `key` (guid, instantiationToken) of the root element. */
static int root_attribute(const char *text, const char *key, char *value, size_t size)
{
    char pattern[64];
    const char *root = strstr(text, "<fmiModelDescription");
    const char *end = root != NULL ? strchr(root, '>') : NULL;
    const char *start;
    const char *stop;
    snprintf(pattern, sizeof pattern, " %s=\"", key);
    start = root != NULL ? strstr(root, pattern) : NULL;
    if (start == NULL || start > end) {
        return 0;
    }
    start += strlen(pattern);
    stop = strchr(start, '"');
    if (stop == NULL || (size_t)(stop - start) >= size) {
        return 0;
    }
    memcpy(value, start, (size_t)(stop - start));
    value[stop - start] = '\0';
    return 1;
}

/* The value reference of the variable `name`: the first element with name="<name>" and
   a valueReference (a unit of the same name has none). */
static int value_reference(const char *text, const char *name, unsigned int *vr)
{
    char pattern[128];
    const char *at = text;
    snprintf(pattern, sizeof pattern, " name=\"%s\"", name);
    while ((at = strstr(at, pattern)) != NULL) {
        const char *end = strchr(at, '>');
        const char *ref = strstr(at, " valueReference=\"");
        at += strlen(pattern);
        if (end != NULL && ref != NULL && ref < end) {
            *vr = (unsigned int)strtoul(ref + strlen(" valueReference=\""), NULL, 10);
            return 1;
        }
    }
    fprintf(stderr, "no variable %s in modelDescription.xml\n", name);
    return 0;
}

/* The value references of RUN_INPUTS and RUN_OUTPUTS. */
static int run_value_references(const char *text, unsigned int *inputs, unsigned int *outputs)
{
    int i;
    int ok = 1;
    for (i = 0; i < N_RUN_INPUTS; i++) {
        ok &= value_reference(text, RUN_INPUTS[i], &inputs[i]);
    }
    for (i = 0; i < N_RUN_OUTPUTS; i++) {
        ok &= value_reference(text, RUN_OUTPUTS[i], &outputs[i]);
    }
    return ok;
}

#endif /* SHIP_HOST_MANOEUVRE_H */
