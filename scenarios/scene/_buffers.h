/*
 * Taking numpy arrays in the compiled code (scenarios/scene/_road_kernels.c and
 * sdc/car/_geometry_kernels.c): a float64, C-contiguous buffer of whole rows, or a TypeError
 * naming the argument.
 */
#ifndef SDC_BUFFERS_H
#define SDC_BUFFERS_H

#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <string.h>

/* the buffer of obj, as rows of `row` doubles (their number in *count);
 * writable for outputs. The caller releases the view. */
static int get_doubles(PyObject *obj, Py_buffer *view, int writable, Py_ssize_t row,
                       Py_ssize_t *count, const char *name) {
    int flags = PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | (writable ? PyBUF_WRITABLE : 0);
    if (PyObject_GetBuffer(obj, view, flags) < 0) return -1;
    if (view->itemsize != 8 || view->format == NULL || strcmp(view->format, "d") != 0
        || (view->len / 8) % row != 0) {
        PyErr_Format(PyExc_TypeError, "%s: a C-contiguous float64 array with rows of %zd",
                     name, row);
        PyBuffer_Release(view);
        return -1;
    }
    *count = view->len / 8 / row;
    return 0;
}

#endif
