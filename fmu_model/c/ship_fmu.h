/*
 * ship_fmu.h - the contract between the hand-written FMI layer and the model part
 * generated from fmu_model for one FMU.
 *
 * The layer is one file per FMI API version (fmi2_functions.c: FMI 2.0 co-simulation and
 * model exchange; fmi3_functions.c: FMI 3.0 co-simulation and model exchange), each of
 * which includes the version-neutral helpers ship_common.c, which include the generated
 * part, two headers, in this order:
 *
 *   model_config.h     (fmu_model.export_native, from fmu_model.interface)
 *     MODEL_GUID              string, the guid (FMI 2.0) or instantiationToken (FMI 3.0)
 *                             of modelDescription.xml
 *     MODEL_IDENTIFIER_NAME   string, the modelIdentifier (for messages)
 *     MODEL_N_VARIABLES       number of Float64 variables; value reference = array index
 *     VR_RUDDER_ANGLE         input, rudder angle [rad]
 *     VR_PROPELLER_RPM        input, propeller speed [rev/min]
 *     VR_STATE                first of the 6 outputs u, v, r, x, y, psi (consecutive): the
 *                             continuous states of model exchange
 *     VR_LENGTH               parameter, ship length [m]
 *     VR_MAX_STEP             parameter, largest internal RK4 step [s]
 *     VR_INITIAL_STATE        first of the 6 parameters u0 ... psi0 (consecutive)
 *     VR_COEFFICIENTS         first of the MODEL_N_COEFFICIENTS coefficients (consecutive,
 *                             in the order model_rhs expects them)
 *     VR_DERIVATIVES          first of the 6 locals der(u) ... der(psi) (consecutive)
 *     VR_TIME                 the independent variable time [s]
 *     VR_ENVIRONMENT          first of the 4 inputs current_speed [m/s], current_direction
 *                             [rad, towards], wind_speed [m/s], wind_direction [rad, from]
 *     VR_GROUND               first of the 2 outputs sog [m/s] and cog [rad], calculated
 *     VR_WINDAGE              first of the 8 windage parameters (frontal_area_m2 ...
 *                             sway_yaw_coupling_kgm, the order of
 *                             fmu_model.environment.Windage)
 *     MODEL_VARIABLES         ShipVariable table, one entry per value reference
 *     DIVERGENCE_MAX_SPEED    bound of |u| and |v| [m/s]; beyond it the state diverged
 *     DIVERGENCE_MAX_YAW_RATE bound of |r| [rad/s]; beyond it the state diverged
 *   (The *_FORMAT strings are printf formats; the layer logs the step and start ones
 *   after "<FMI function>: ".)
 *     DIVERGENCE_FORMAT       printf format of the discard message of a diverged step,
 *                             with the arguments (double): time of the failed internal step
 *                             [s], u, v, r there, DIVERGENCE_MAX_SPEED,
 *                             DIVERGENCE_MAX_YAW_RATE, time the state stays at [s]
 *     DIVERGED_STATE_FORMAT   printf format of the discard message of a model-exchange
 *                             evaluation at a diverged state (double): t [s], u, v, r,
 *                             DIVERGENCE_MAX_SPEED, DIVERGENCE_MAX_YAW_RATE
 *     MAX_SUBSTEPS            largest number of internal steps of one DoStep (double)
 *     SUBSTEP_LIMIT_FORMAT    printf format of the error of a longer step: h [s],
 *                             h / max_step, max_step [s], MAX_SUBSTEPS (all double)
 *     STEP_SIZE_FORMAT        printf format of the error of a step that is not positive
 *                             and finite: h [s]
 *     STEP_TIME_FORMAT        printf format of the error of a step that does not start at
 *                             the FMU's time: currentCommunicationPoint, time [s]
 *     STEP_TIME_TOLERANCE     relative tolerance of that comparison (to 1 + |time|)
 *     TIME_STALL_FORMAT       printf format of the error of a step with t + h == t:
 *                             h [s], t [s] (double)
 *     MIN_START_SPEED         least start speed sqrt(u0^2 + v0^2) [m/s]; 0 when the model
 *                             starts from rest
 *     START_SPEED_FORMAT      printf format of the error of ExitInitializationMode below
 *                             it: start speed, MIN_START_SPEED [m/s] (double)
 *     STATE_RANGE_FORMAT      printf formats of the error of a restored FMU state with a
 *     STATE_NONFINITE_FORMAT  value out of range or not finite: function (string), variable
 *                             name (string), value, and (range) min, max (double)
 *     MODEL_HAS_ENVELOPE      1 when the identification's logs' envelope is known
 *                             (fmu_model.envelope), 0 otherwise (the values below are 0)
 *     ENVELOPE_RUDDER_PORT, ENVELOPE_RUDDER_STARBOARD, ENVELOPE_YAW_RATE_PORT,
 *     ENVELOPE_YAW_RATE_STARBOARD, ENVELOPE_SPEED_RATIO_MIN, ENVELOPE_APPROACH_LOW,
 *     ENVELOPE_APPROACH_HIGH, ENVELOPE_PROPELLER_LOW, ENVELOPE_PROPELLER_HIGH
 *                             its axes [rad, -, -, m/s, rev/s], and ENVELOPE_MARGIN,
 *                             ENVELOPE_SPEED_RATIO_MARGIN,
 *                             ENVELOPE_MIN_SPEED_RATIO_FOR_YAW_RATE, ENVELOPE_DEG_PER_RAD,
 *                             ENVELOPE_RPM_PER_RPS its rule's numbers
 *     ENVELOPE_RUDDER_FORMAT, ENVELOPE_YAW_RATE_FORMAT, ENVELOPE_SPEED_RATIO_FORMAT,
 *     ENVELOPE_SPAN_VALUE_FORMAT, ENVELOPE_SPAN_FORMAT
 *                             printf formats of its phrases, and EXTRAPOLATION_FORMAT the
 *                             warning: function (string), time [s], phrase (string)
 *
 *   model_equations.h  (fmu_model.codegen.generate_model_c, from the symbolic structure)
 *     MODEL_N_COEFFICIENTS, MODEL_COEFFICIENT_NAMES and
 *     static void model_rhs(const double *theta, double length, const double *x,
 *                           double rudder, double n_rps, double *dx)
 *     with x = (u, v, r, x, y, psi) and dx its time derivative, and
 *     static void model_jacobian(const double *theta, double length, const double *x,
 *                                double rudder, double n_rps, double *dfdx, double *dfdu)
 *     its exact partial derivatives, row-major: dfdx 6 x 6 (by x), dfdu 6 x 2 (by rudder
 *     [rad] and n_rps [rev/s]), and the environment's part of the model:
 *     static void model_environment(const double *x, const double *env,
 *                                   const double *windage, double *dx)
 *     adds the wind's accelerations and the current's velocity to dx;
 *     static void model_environment_jacobian(const double *x, const double *env,
 *                                            const double *windage, double *dfdx,
 *                                            double *dfde)
 *     adds their partial derivatives by x to dfdx and writes those by env to dfde (6 x 4);
 *     static void model_ground(const double *x, const double *env, double *g)
 *     g = (speed over ground, course over ground), and
 *     static void model_ground_jacobian(const double *x, const double *env, double *dgdx,
 *                                       double *dgde)
 *     their partial derivatives, dgdx 2 x 6, dgde 2 x 4.
 *
 * Nothing in the layer depends on the model variant beyond these names.
 */
#ifndef SHIP_FMU_H
#define SHIP_FMU_H

/* Number of states (u, v, r, x, y, psi) integrated by the layer. */
#define SHIP_N_STATES 6
/* Number of inputs of the model (rudder angle, propeller speed). */
#define SHIP_N_INPUTS 2
/* Number of environment inputs (current speed and direction, wind speed and direction). */
#define SHIP_N_ENVIRONMENT 4
/* Number of windage parameters (fmu_model.environment.Windage). */
#define SHIP_N_WINDAGE 8
/* Number of outputs over ground (sog, cog). */
#define SHIP_N_GROUND 2

typedef enum {
    SHIP_INPUT = 0,      /* settable before and after initialisation */
    SHIP_OUTPUT = 1,     /* never settable; a state of the integrator */
    SHIP_PARAMETER = 2,  /* fixed: settable only before ExitInitializationMode */
    SHIP_LOCAL = 3,      /* never settable; a state derivative, calculated */
    SHIP_INDEPENDENT = 4 /* never settable; the time */
} ShipCausality;

/* One Float64 variable of the FMU; the table index is its value reference. */
typedef struct {
    const char *name;
    ShipCausality causality;
    double start; /* start value; unused (0) for outputs, locals and the time */
    int has_min;  /* nonzero when min is declared */
    double min;
    int has_max; /* nonzero when max is declared */
    double max;
} ShipVariable;

#endif /* SHIP_FMU_H */
