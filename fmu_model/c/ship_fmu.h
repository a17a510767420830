/*
 * ship_fmu.h - the contract between the hand-written FMI 2.0 co-simulation layer
 * (fmi2_cosimulation.c) and the model part generated from fmu_model for one FMU.
 *
 * The generated part is two headers, included by fmi2_cosimulation.c in this order:
 *
 *   model_config.h     (fmu_model.export_native, from fmu_model.interface.fmu_variables)
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
