/*
 * The SUMO world's step without libsumo's Python layer (scenarios/sumo_world.py):
 * push the ego, advance SUMO, and read the traffic around the ego into boxes.
 *
 * libsumo's Python module is SUMO itself, compiled together with its C++ API
 * (libsumo::Vehicle, libsumo::Simulation, ...), and it exports that API. bind()
 * looks those functions up in the already loaded module, by their C++ (Itanium
 * ABI) names, so every call here reaches the very simulation that libsumo's
 * Python side started, and does what the same Python call does: through SWIG, a
 * step's four calls and the conversion of the subscription's results into dicts
 * cost more than SUMO's own work for them.
 *
 * Only the few shapes this file reads are declared here: a subscription's results
 * map vehicle ids (sorted, as std::map keeps them) to {variable id: result}, and a
 * result is a polymorphic object holding doubles (libsumo's TraCIDefs.h).
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <dlfcn.h>

#include <exception>
#include <map>
#include <memory>
#include <string>

#include "_buffers.h"
#include "_traffic_box.h"

namespace {

/* libsumo::TraCIResult: polymorphic, so its vtable pointer comes before the data.
 * Only data members are read here; no virtual method is called through this view. */
struct Result {
    virtual ~Result() {}
};
struct Position : Result {  // libsumo::TraCIPosition
    double x, y, z;
};
struct Double : Result {  // libsumo::TraCIDouble
    double value;
};
typedef std::map<int, std::shared_ptr<Result>> Variables;
typedef std::map<std::string, Variables> ContextResults;

typedef void (*MoveToXY)(const std::string &, const std::string &, int, double, double, double,
                         int, double);
typedef void (*SetSpeed)(const std::string &, double);
typedef void (*Step)(double);
typedef double (*GetTime)();
typedef ContextResults (*GetContextResults)(const std::string &);

#define STRING_REF "RKNSt7__cxx1112basic_stringIcSt11char_traitsIcESaIcEEE"
/* libsumo::Vehicle::moveToXY(const string& vehID, const string& edgeID, int laneIndex,
 * double x, double y, double angle, int keepRoute, double matchThreshold) */
const char *const MOVE_TO_XY = "_ZN7libsumo7Vehicle8moveToXYE" STRING_REF "S8_idddid";
/* libsumo::Vehicle::setSpeed(const string& vehID, double speed) */
const char *const SET_SPEED = "_ZN7libsumo7Vehicle8setSpeedE" STRING_REF "d";
/* libsumo::Simulation::step(double time) */
const char *const STEP = "_ZN7libsumo10Simulation4stepEd";
/* libsumo::Simulation::getTime() */
const char *const GET_TIME = "_ZN7libsumo10Simulation7getTimeEv";
/* libsumo::Vehicle::getContextSubscriptionResults(const string& objectID) */
const char *const CONTEXT_RESULTS =
    "_ZN7libsumo7Vehicle29getContextSubscriptionResultsE" STRING_REF;
/* libsumo's Python default for moveToXY's matchThreshold [m] */
const double MATCH_THRESHOLD_M = 100.0;
/* moveToXY's keepRoute: 2 = anywhere on the network, off the route too */
const int ANYWHERE = 2;

struct Api {
    MoveToXY move_to_xy;
    SetSpeed set_speed;
    Step step;
    GetTime get_time;
    GetContextResults context_results;
    PyObject *error;  // what a failing call raises: libsumo's TraCIException
};

/* the module's state: the functions bind() found, and libsumo's exception type */
Api *api(PyObject *module) { return static_cast<Api *>(PyModule_GetState(module)); }

PyObject *unbound(void) {
    PyErr_SetString(PyExc_RuntimeError, "_sumo_step: bind() to libsumo first");
    return NULL;
}

/* bind(path, error): find SUMO's C++ API in libsumo's loaded module at `path`
 * (libsumo._libsumo.__file__); False when it is not loaded or lacks a function */
PyObject *bind(PyObject *module, PyObject *args) {
    const char *path;
    PyObject *error;
    if (!PyArg_ParseTuple(args, "sO", &path, &error)) return NULL;
    Api *a = api(module);
    void *library = dlopen(path, RTLD_NOW | RTLD_NOLOAD);  // only if already loaded
    if (library == NULL) Py_RETURN_FALSE;
    Api found = {
        reinterpret_cast<MoveToXY>(dlsym(library, MOVE_TO_XY)),
        reinterpret_cast<SetSpeed>(dlsym(library, SET_SPEED)),
        reinterpret_cast<Step>(dlsym(library, STEP)),
        reinterpret_cast<GetTime>(dlsym(library, GET_TIME)),
        reinterpret_cast<GetContextResults>(dlsym(library, CONTEXT_RESULTS)),
        error,
    };
    dlclose(library);  // the module stays loaded: libsumo holds it
    if (!found.move_to_xy || !found.set_speed || !found.step || !found.get_time
        || !found.context_results)
        Py_RETURN_FALSE;
    Py_INCREF(error);
    Py_XDECREF(a->error);
    *a = found;
    Py_RETURN_TRUE;
}

PyObject *fail(const Api *a, const std::exception &e) {
    PyErr_SetString(a->error, e.what());
    return NULL;
}

/* step(ego_id, x, y, angle_deg, speed_mps): place the ego's front bumper at (x, y)
 * heading angle_deg (SUMO's degrees), anywhere on the network, at speed_mps;
 * advance SUMO one step; return SUMO's time [s] */
PyObject *step(PyObject *module, PyObject *args) {
    const char *ego;
    Py_ssize_t ego_len;
    double x, y, angle_deg, speed_mps;
    if (!PyArg_ParseTuple(args, "s#dddd", &ego, &ego_len, &x, &y, &angle_deg, &speed_mps))
        return NULL;
    const Api *a = api(module);
    if (a->step == NULL) return unbound();
    try {
        const std::string id(ego, ego_len), any_edge;
        a->move_to_xy(id, any_edge, -1, x, y, angle_deg, ANYWHERE, MATCH_THRESHOLD_M);
        a->set_speed(id, speed_mps);
        a->step(0.0);
        return PyFloat_FromDouble(a->get_time());
    } catch (const std::exception &e) {
        return fail(a, e);
    }
}

/* the result of variable `key` (libsumo makes a position a TraCIPosition, an angle
 * or a speed a TraCIDouble) */
template <typename T>
const T &result_of(const Variables &variables, int key) {
    return static_cast<const T &>(*variables.at(key));
}

/* traffic(ego_id, (position key, angle key, speed key), skip_prefix, length, width,
 * cx, cy, radius, boxes, speeds): the ego's context subscription results, read as
 * scenarios/_kernels.c's traffic() reads libsumo's dict of them (same vehicles, same
 * order, same boxes); returns how many, or minus the number of results when boxes
 * and speeds have no room for them all (nothing written) */
PyObject *traffic(PyObject *module, PyObject *args) {
    const char *ego, *skip;
    Py_ssize_t ego_len, skip_len;
    int key_position, key_angle, key_speed;
    double length, width, cx, cy, radius;
    PyObject *b_obj, *s_obj;
    if (!PyArg_ParseTuple(args, "s#(iii)s#dddddOO", &ego, &ego_len, &key_position, &key_angle,
                          &key_speed, &skip, &skip_len, &length, &width, &cx, &cy, &radius,
                          &b_obj, &s_obj))
        return NULL;
    const Api *a = api(module);
    if (a->context_results == NULL) return unbound();
    Py_buffer bv, sv;
    Py_ssize_t n_boxes, n_speeds;
    if (get_doubles(b_obj, &bv, 1, 5, &n_boxes, "boxes") < 0) return NULL;
    if (get_doubles(s_obj, &sv, 1, 1, &n_speeds, "speeds") < 0) {
        PyBuffer_Release(&bv);
        return NULL;
    }
    PyObject *result = NULL;
    try {
        const std::string id(ego, ego_len), prefix(skip, skip_len);
        const ContextResults nearby = a->context_results(id);
        Py_ssize_t n = static_cast<Py_ssize_t>(nearby.size()), count = 0;
        if (n > n_boxes || n > n_speeds) {
            result = PyLong_FromSsize_t(-n);
        } else {
            double *boxes = static_cast<double *>(bv.buf), *speeds = static_cast<double *>(sv.buf);
            for (const auto &[vid, variables] : nearby) {
                if (vid == id || vid.compare(0, prefix.size(), prefix) == 0) continue;
                const Position &front = result_of<Position>(variables, key_position);
                double angle_deg = result_of<Double>(variables, key_angle).value;
                if (traffic_box(front.x, front.y, angle_deg, length, width, cx, cy, radius,
                                boxes + 5 * count))
                    speeds[count++] = result_of<Double>(variables, key_speed).value;
            }
            result = PyLong_FromSsize_t(count);
        }
    } catch (const std::exception &e) {
        result = fail(a, e);
    }
    PyBuffer_Release(&sv);
    PyBuffer_Release(&bv);
    return result;
}

int clear(PyObject *module) {
    Py_CLEAR(api(module)->error);
    return 0;
}

void free_module(void *module) { clear(static_cast<PyObject *>(module)); }

PyMethodDef methods[] = {
    {"bind", bind, METH_VARARGS, "Find SUMO's C++ API in libsumo's loaded module."},
    {"step", step, METH_VARARGS, "Push the ego, advance SUMO one step, return its time."},
    {"traffic", traffic, METH_VARARGS, "Traffic boxes and speeds from the ego's context."},
    {NULL, NULL, 0, NULL},
};

PyModuleDef module_def = {
    PyModuleDef_HEAD_INIT, "_sumo_step", NULL, sizeof(Api), methods, NULL, NULL, clear,
    free_module,
};

}  // namespace

PyMODINIT_FUNC PyInit__sumo_step(void) { return PyModule_Create(&module_def); }
