/*
 * ship_fmu.h - the contract between the hand-written FMI 2.0 co-simulation layer
 * (fmi2_cosimulation.c) and the model part generated from fmu_model for one FMU.
 *
 * The generated part is two headers, included by fmi2_cosimulation.c in this order:
 *
 *   model_config.h     (fmu_model.export_native, from fmu_model.interface)
 *     MODEL_GUID              string, must equal the guid of modelDescription.xml
 *     MODEL_IDENTIFIER_NAME   string, the modelIdentifier (for messages)
 *     MODEL_N_VARIABLES       number of Real variables; value reference = array index
 *     VR_RUDDER_ANGLE         input, rudder angle [rad]
 *     VR_PROPELLER_RPM        input, propeller speed [rev/min]
 *     VR_STATE                first of the 6 outputs u, v, r, x, y, psi (consecutive)
 *     VR_LENGTH               parameter, ship length [m]
 *     VR_MAX_STEP             parameter, largest internal RK4 step [s]
 *     VR_INITIAL_STATE        first of the 6 parameters u0 ... psi0 (consecutive)
 *     VR_COEFFICIENTS         first of the MODEL_N_COEFFICIENTS coefficients (consecutive,
 *                             in the order model_rhs expects them)
 *     MODEL_VARIABLES         ShipVariable table, one entry per value reference
 *     DIVERGENCE_MAX_SPEED    bound of |u| and |v| [m/s]; beyond it the state diverged
 *     DIVERGENCE_MAX_YAW_RATE bound of |r| [rad/s]; beyond it the state diverged
 *     DIVERGENCE_FORMAT       printf format of the fmi2Discard message of a diverged step,
 *                             with the arguments (double): time of the failed internal step
 *                             [s], u, v, r there, DIVERGENCE_MAX_SPEED,
 *                             DIVERGENCE_MAX_YAW_RATE, time the state stays at [s]
 *     MAX_SUBSTEPS            largest number of internal steps of one fmi2DoStep (double)
 *     SUBSTEP_LIMIT_FORMAT    printf format of the fmi2Error of a longer step: h [s],
 *                             h / max_step, max_step [s], MAX_SUBSTEPS (all double)
 *     TIME_STALL_FORMAT       printf format of the fmi2Error of a step with t + h == t:
 *                             h [s], t [s] (double)
 *     MIN_START_SPEED         least start speed sqrt(u0^2 + v0^2) [m/s]; 0 when the model
 *                             starts from rest
 *     START_SPEED_FORMAT      printf format of the fmi2Error of fmi2ExitInitializationMode
 *                             below it: start speed, MIN_START_SPEED [m/s] (double)
 *     STATE_RANGE_FORMAT      printf formats of the fmi2Error of a restored FMU state with a
 *     STATE_NONFINITE_FORMAT  value out of range or not finite: function (string), variable
 *                             name (string), value, and (range) min, max (double)
 *
 *   model_equations.h  (fmu_model.codegen.generate_model_c, from the symbolic structure)
 *     MODEL_N_COEFFICIENTS, MODEL_COEFFICIENT_NAMES and
 *     static void model_rhs(const double *theta, double length, const double *x,
 *                           double rudder, double n_rps, double *dx)
 *     with x = (u, v, r, x, y, psi) and dx its time derivative.
 *
 * Nothing in the layer depends on the model variant beyond these names.
 */
#ifndef SHIP_FMU_H
#define SHIP_FMU_H

/* Number of states (u, v, r, x, y, psi) integrated by the layer. */
#define SHIP_N_STATES 6

typedef enum {
    SHIP_INPUT = 0,    /* settable before and after initialisation */
    SHIP_OUTPUT = 1,   /* never settable; a state of the integrator */
    SHIP_PARAMETER = 2 /* fixed: settable only before fmi2ExitInitializationMode */
} ShipCausality;

/* One Real variable of the FMU; the table index is its value reference. */
typedef struct {
    const char *name;
    ShipCausality causality;
    double start; /* start value; unused (0) for outputs */
    int has_min;  /* nonzero when min is declared */
    double min;
    int has_max; /* nonzero when max is declared */
    double max;
} ShipVariable;

#endif /* SHIP_FMU_H */
