/*
 * The common case of the ANDOR text reader, compiled: flexhrc.representation.formats.andor_text
 * uses it when it is built (it is optional; the pure-Python reader is the reference).
 *
 * parse(data: bytes) -> tuple | None
 * parse_file(path) -> tuple | bytes | None   (the bytes it read and declined; None: unreadable)
 *
 * Reads one ANDOR text file that the pure-Python fast path (andor_text._parse_flat) accepts --
 * plain names, integer weights, no repeated name, children listed before the hyper-arcs that
 * consume their parents -- and returns exactly what that path builds, as flat arrays (see
 * andor_text._from_compiled). For anything else, and for every fault, it returns None: the Python
 * reader then parses the file and names the fault, so every message comes from one place.
 * It accepts less than the Python fast path (ASCII only, no comment, only space and tab between
 * tokens, at most 15 digits in a number); never more.
 *
 * Why it exists: a graph is loaded in a fresh process (flexhrc graph play, a cell starting),
 * and there the Python reader's cost is mostly the fixed work of its code per file, not the
 * tokens (issue 9: the offline phase of the 32-file kitchen against the C++ ANDOR).
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <errno.h>
#include <fcntl.h>
#include <stdint.h>
#include <string.h>
#include <unistd.h>

typedef struct {
    const char *s;
    Py_ssize_t n;
} Tok;

typedef struct {
    Py_ssize_t first; /* index of its first token */
    Py_ssize_t count; /* number of tokens */
    long line;        /* 1-based line number */
} Row;

/* ------------------------------------------------------------------ name table ---- */
typedef struct {
    Py_ssize_t cap; /* a power of two */
    Py_ssize_t *slot; /* id + 1, 0 = empty */
    const Tok *keys; /* the tokens the ids index */
} Table;

static uint64_t
hash_tok(const Tok *t)
{
    uint64_t h = 1469598103934665603ULL; /* FNV-1a */
    for (Py_ssize_t i = 0; i < t->n; i++) {
        h ^= (unsigned char)t->s[i];
        h *= 1099511628211ULL;
    }
    return h;
}

static int
table_init(Table *tb, Py_ssize_t n, const Tok *keys)
{
    Py_ssize_t cap = 8;
    while (cap < 2 * n + 2) {
        cap <<= 1;
    }
    tb->slot = PyMem_Calloc((size_t)cap, sizeof(Py_ssize_t));
    tb->cap = cap;
    tb->keys = keys;
    return tb->slot != NULL;
}

/* The id of a name, or -1. */
static Py_ssize_t
table_get(const Table *tb, const Tok *t)
{
    Py_ssize_t mask = tb->cap - 1;
    Py_ssize_t i = (Py_ssize_t)(hash_tok(t) & (uint64_t)mask);
    while (tb->slot[i]) {
        const Tok *k = &tb->keys[tb->slot[i] - 1];
        if (k->n == t->n && memcmp(k->s, t->s, (size_t)t->n) == 0) {
            return tb->slot[i] - 1;
        }
        i = (i + 1) & mask;
    }
    return -1;
}

/* Adds keys[id]; 0 if the name is there already. */
static int
table_add(Table *tb, Py_ssize_t id)
{
    const Tok *t = &tb->keys[id];
    Py_ssize_t mask = tb->cap - 1;
    Py_ssize_t i = (Py_ssize_t)(hash_tok(t) & (uint64_t)mask);
    while (tb->slot[i]) {
        const Tok *k = &tb->keys[tb->slot[i] - 1];
        if (k->n == t->n && memcmp(k->s, t->s, (size_t)t->n) == 0) {
            return 0;
        }
        i = (i + 1) & mask;
    }
    tb->slot[i] = id + 1;
    return 1;
}

/* ------------------------------------------------------------------ helpers -------- */
/* The weights of the authors' files are small integers: one float object per value, made at
 * import (float() would make one per element). */
#define N_SMALL_FLOATS 256
static PyObject *small_floats[N_SMALL_FLOATS];

static PyObject *
weight_obj(int64_t v)
{
    if (v < N_SMALL_FLOATS) {
        Py_INCREF(small_floats[v]);
        return small_floats[v];
    }
    return PyFloat_FromDouble((double)v);
}

static int
all_digits(const Tok *t)
{
    for (Py_ssize_t i = 0; i < t->n; i++) {
        if (t->s[i] < '0' || t->s[i] > '9') {
            return 0;
        }
    }
    return t->n > 0;
}

/* The value of a token of 1..15 ASCII digits (exact as a double: below 2**53), or -1. */
static int64_t
digits_value(const Tok *t)
{
    if (t->n > 15 || !all_digits(t)) {
        return -1;
    }
    int64_t v = 0;
    for (Py_ssize_t i = 0; i < t->n; i++) {
        v = v * 10 + (t->s[i] - '0');
    }
    return v;
}

static int
has_slash(const Tok *t)
{
    return memchr(t->s, '/', (size_t)t->n) != NULL;
}

static PyObject *
tok_str(const Tok *t)
{
    return PyUnicode_DecodeASCII(t->s, t->n, NULL);
}

/* A tuple of ints and strings can be in no reference cycle: the cyclic collector need not track
 * it (it finds that out itself in its first pass over it, after scanning it once). A graph has
 * a tuple per node and per hyper-arc: tracked, they alone make a load cross the collector's
 * threshold and pay a pass. */
static void
untrack(PyObject *t)
{
    if (t != NULL && PyObject_GC_IsTracked(t)) {
        PyObject_GC_UnTrack(t);
    }
}

/* An untracked tuple of the ``m`` ids at ``ids`` (``empty`` when there are none); NULL on
 * failure. */
static PyObject *
id_tuple(const Py_ssize_t *ids, Py_ssize_t m, PyObject *empty)
{
    if (m == 0) {
        Py_INCREF(empty);
        return empty;
    }
    PyObject *t = PyTuple_New(m);
    if (t == NULL) {
        return NULL;
    }
    for (Py_ssize_t d = 0; d < m; d++) {
        PyObject *v = PyLong_FromSsize_t(ids[d]);
        if (v == NULL) {
            Py_DECREF(t);
            return NULL;
        }
        PyTuple_SET_ITEM(t, d, v);
    }
    untrack(t);
    return t;
}

/* Tokens and non-blank rows, as str.split() of each line of str.splitlines() gives them for
 * the texts accepted here; 0 for a text this reader leaves to Python. */
static int
tokenize(const char *s, Py_ssize_t n, Tok **toks_out, Py_ssize_t *ntok, Row **rows_out,
         Py_ssize_t *nrows)
{
    /* a row has at most 5 tokens in a file read here (more: declined below) */
    Py_ssize_t cap_r = 1;
    for (const char *q = s; (q = memchr(q, '\n', (size_t)(s + n - q))) != NULL; q++) {
        cap_r++;
    }
    Py_ssize_t cap_t = 5 * cap_r;
    Tok *toks = PyMem_Malloc((size_t)cap_t * sizeof(Tok));
    Row *rows = PyMem_Malloc((size_t)cap_r * sizeof(Row));
    if (toks == NULL || rows == NULL) {
        PyMem_Free(toks);
        PyMem_Free(rows);
        return 0;
    }
    Py_ssize_t nt = 0, nr = 0, i = 0;
    long line = 1;
    if (n >= 3 && memcmp(s, "\xef\xbb\xbf", 3) == 0) {
        i = 3; /* a byte-order mark (the Python reader drops it too) */
    }
    Py_ssize_t row_first = 0;
    while (i <= n) {
        unsigned char c = i < n ? (unsigned char)s[i] : '\n';
        if (c == ' ' || c == '\t') {
            i++;
            continue;
        }
        if (c == '\r') {
            if (i + 1 < n && s[i + 1] == '\n') {
                i++;
                continue; /* the \n ends the line */
            }
            goto refuse; /* a lone \r is a line break of its own for splitlines() */
        }
        if (c == '\n') {
            if (nt > row_first) {
                rows[nr].first = row_first;
                rows[nr].count = nt - row_first;
                rows[nr].line = line;
                nr++;
            }
            row_first = nt;
            line++;
            i++;
            continue;
        }
        if (c < 0x20 || c >= 0x80 || c == '#') {
            goto refuse; /* control characters, non-ASCII, comments: Python's business */
        }
        if (nt - row_first == 5) {
            goto refuse; /* a sixth field: no line of an ANDOR file has one */
        }
        Py_ssize_t start = i;
        while (i < n) {
            unsigned char d = (unsigned char)s[i];
            if (d <= ' ' || d >= 0x80 || d == '#') {
                break;
            }
            i++;
        }
        toks[nt].s = s + start;
        toks[nt].n = i - start;
        nt++;
    }
    *toks_out = toks;
    *ntok = nt;
    *rows_out = rows;
    *nrows = nr;
    return 1;
refuse:
    PyMem_Free(toks);
    PyMem_Free(rows);
    return 0;
}

/* ------------------------------------------------------------------ the parse ------ */
static PyObject *
build(const Tok *toks, const Row *rows, Py_ssize_t nrows)
{
    PyObject *result = NULL;
    Py_ssize_t *child_ids = NULL, *child_off = NULL, *parent = NULL, *last = NULL;
    Py_ssize_t *inc_count = NULL, *inc_off = NULL, *inc_ids = NULL;
    long *lines = NULL;
    char *consumed = NULL;
    Py_ssize_t *arc_tok = NULL; /* first token of each hyper-arc row */
    Tok *names = NULL;
    Table nodes_tb = {0, NULL, NULL}, arcs_tb = {0, NULL, NULL};

    if (nrows < 1 || rows[0].count != 3) {
        return Py_None;
    }
    const Tok *head = &toks[rows[0].first];
    int64_t nn64 = all_digits(&head[1]) && head[1].n <= 9 ? digits_value(&head[1]) : -1;
    if (nn64 <= 0 || nn64 >= nrows - 1) {
        return Py_None;
    }
    Py_ssize_t nn = (Py_ssize_t)nn64;
    /* at most one hyper-arc per remaining row */
    Py_ssize_t max_el = nn + (nrows - 1 - nn);
    names = PyMem_Malloc((size_t)max_el * sizeof(Tok));
    lines = PyMem_Malloc((size_t)max_el * sizeof(long));
    parent = PyMem_Malloc((size_t)max_el * sizeof(Py_ssize_t));
    child_off = PyMem_Malloc((size_t)(max_el + 1) * sizeof(Py_ssize_t));
    child_ids = PyMem_Malloc((size_t)(nrows + 1) * sizeof(Py_ssize_t));
    arc_tok = PyMem_Malloc((size_t)max_el * sizeof(Py_ssize_t));
    last = PyMem_Malloc((size_t)nn * sizeof(Py_ssize_t));
    consumed = PyMem_Calloc((size_t)nn, 1);
    inc_count = PyMem_Calloc((size_t)nn + 1, sizeof(Py_ssize_t));
    if (!names || !lines || !parent || !child_off || !child_ids || !arc_tok || !last ||
        !consumed || !inc_count) {
        result = PyErr_NoMemory();
        goto done;
    }
    int zero_weights = 1;
    for (Py_ssize_t x = 0; x < nn; x++) {
        const Row *r = &rows[1 + x];
        if (r->count != 2) {
            result = Py_None;
            goto done;
        }
        const Tok *w = &toks[r->first + 1];
        if (digits_value(w) < 0 || has_slash(&toks[r->first])) {
            result = Py_None;
            goto done;
        }
        if (w->n != 1 || w->s[0] != '0') {
            zero_weights = 0;
        }
        names[x] = toks[r->first];
        lines[x] = r->line;
        parent[x] = -1;
        last[x] = -1;
    }
    if (!table_init(&nodes_tb, nn, names)) {
        result = PyErr_NoMemory();
        goto done;
    }
    for (Py_ssize_t x = 0; x < nn; x++) {
        if (!table_add(&nodes_tb, x)) {
            result = Py_None; /* a repeated node name */
            goto done;
        }
    }
    Py_ssize_t root = table_get(&nodes_tb, &head[2]);
    if (root < 0) {
        result = Py_None;
        goto done;
    }
    Py_ssize_t i = nn + 1, j = nn, nc = 0;
    while (i < nrows) {
        const Row *r = &rows[i];
        if (r->count != 5) {
            result = Py_None;
            goto done;
        }
        const Tok *h = &toks[r->first];
        int64_t k = h[1].n <= 9 ? digits_value(&h[1]) : -1;
        if (k < 1 || i + k >= nrows || digits_value(&h[3]) < 0 || has_slash(&h[0])) {
            result = Py_None;
            goto done;
        }
        Py_ssize_t p = table_get(&nodes_tb, &h[2]);
        if (p < 0 || consumed[p]) {
            /* an unknown parent; or one consumed by an earlier hyper-arc: the file is not in
             * the order the cost pass follows (the Python reader sorts it) */
            result = Py_None;
            goto done;
        }
        child_off[j] = nc;
        for (Py_ssize_t c = 0; c < k; c++) {
            const Row *cr = &rows[i + 1 + c];
            if (cr->count != 1) {
                result = Py_None;
                goto done;
            }
            Py_ssize_t id = table_get(&nodes_tb, &toks[cr->first]);
            if (id < 0 || id == p) {
                result = Py_None;
                goto done;
            }
            for (Py_ssize_t d = child_off[j]; d < nc; d++) {
                if (child_ids[d] == id) {
                    result = Py_None; /* a child twice */
                    goto done;
                }
            }
            child_ids[nc++] = id;
        }
        for (Py_ssize_t d = child_off[j]; d < nc; d++) {
            consumed[child_ids[d]] = 1;
        }
        names[j] = h[0];
        lines[j] = r->line;
        parent[j] = p;
        arc_tok[j] = r->first;
        inc_count[p]++;
        last[p] = j;
        i += k + 1;
        j++;
    }
    child_off[j] = nc;
    if (consumed[root]) {
        result = Py_None; /* the root is a child */
        goto done;
    }
    if (!table_init(&arcs_tb, j - nn, names + nn)) {
        result = PyErr_NoMemory();
        goto done;
    }
    for (Py_ssize_t x = 0; x < j - nn; x++) {
        if (!table_add(&arcs_tb, x)) {
            result = Py_None; /* a repeated hyper-arc name: the Python reader renames it */
            goto done;
        }
    }

    /* incoming hyper-arcs of each node, in hyper-arc order */
    inc_off = PyMem_Malloc((size_t)(nn + 1) * sizeof(Py_ssize_t));
    inc_ids = PyMem_Malloc((size_t)(j - nn + 1) * sizeof(Py_ssize_t));
    if (!inc_off || !inc_ids) {
        result = PyErr_NoMemory();
        goto done;
    }
    inc_off[0] = 0;
    for (Py_ssize_t x = 0; x < nn; x++) {
        inc_off[x + 1] = inc_off[x] + inc_count[x];
        inc_count[x] = 0;
    }
    for (Py_ssize_t a = nn; a < j; a++) {
        Py_ssize_t p = parent[a];
        inc_ids[inc_off[p] + inc_count[p]++] = a;
    }

    /* ---- the Python objects ---- */
    Py_ssize_t size = j;
    PyObject *o_names = PyList_New(size), *o_weights = PyList_New(size);
    PyObject *o_children = PyList_New(size), *o_parent = PyList_New(size);
    PyObject *o_inc = PyList_New(size), *o_lower = PyList_New(0), *o_refs = PyList_New(0);
    PyObject *o_topo = NULL, *o_leaves = NULL, *o_lines = PyList_New(size);
    PyObject *o_dead = PyList_New(0), *empty = PyTuple_New(0);
    PyObject *o_name = tok_str(&head[0]), *o_root_name = tok_str(&head[2]);
    PyObject *zero = PyFloat_FromDouble(0.0), *minus = PyLong_FromLong(-1);
    if (!o_names || !o_weights || !o_children || !o_parent || !o_inc || !o_lower || !o_refs ||
        !o_lines || !o_dead || !empty || !o_name || !o_root_name ||
        !zero || !minus) {
        goto fail;
    }
#define SET(list, idx, expr)                                                                   \
    do {                                                                                       \
        PyObject *v_ = (expr);                                                                 \
        if (v_ == NULL) goto fail;                                                             \
        PyList_SET_ITEM(list, idx, v_);                                                        \
    } while (0)
#define APPEND(list, expr)                                                                     \
    do {                                                                                       \
        PyObject *v_ = (expr);                                                                 \
        if (v_ == NULL || PyList_Append(list, v_) < 0) {                                       \
            Py_XDECREF(v_);                                                                    \
            goto fail;                                                                         \
        }                                                                                      \
        Py_DECREF(v_);                                                                         \
    } while (0)
    for (Py_ssize_t x = 0; x < size; x++) {
        SET(o_names, x, tok_str(&names[x]));
        SET(o_lines, x, PyLong_FromLong(lines[x]));
    }
    for (Py_ssize_t x = 0; x < nn; x++) {
        const Tok *w = &toks[rows[1 + x].first + 1];
        if (zero_weights) {
            Py_INCREF(zero);
            PyList_SET_ITEM(o_weights, x, zero);
        }
        else {
            SET(o_weights, x, weight_obj(digits_value(w)));
        }
        Py_INCREF(empty);
        PyList_SET_ITEM(o_children, x, empty);
        Py_INCREF(minus);
        PyList_SET_ITEM(o_parent, x, minus);
        SET(o_inc, x, id_tuple(inc_ids + inc_off[x], inc_off[x + 1] - inc_off[x], empty));
    }
    for (Py_ssize_t a = nn; a < size; a++) {
        const Tok *h = &toks[arc_tok[a]];
        SET(o_weights, a, weight_obj(digits_value(&h[3])));
        SET(o_children, a,
            id_tuple(child_ids + child_off[a], child_off[a + 1] - child_off[a], empty));
        SET(o_parent, a, PyLong_FromSsize_t(parent[a]));
        Py_INCREF(empty);
        PyList_SET_ITEM(o_inc, a, empty);
        if (!(h[4].n == 1 && h[4].s[0] == '-')) {
            PyObject *low = tok_str(&h[4]);
            if (low == NULL) goto fail;
            PyObject *pair = Py_BuildValue("(nO)", a, low);
            PyObject *ref = Py_BuildValue("(Ol)", low, lines[a]);
            Py_DECREF(low);
            untrack(pair);
            untrack(ref);
            int bad = pair == NULL || ref == NULL || PyList_Append(o_lower, pair) < 0 ||
                      PyList_Append(o_refs, ref) < 0;
            Py_XDECREF(pair);
            Py_XDECREF(ref);
            if (bad) goto fail;
        }
    }
    /* the leaves in id order, then each hyper-arc and, after the last hyper-arc into it, its
     * parent: a topological order when children come before the hyper-arcs using them */
    Py_ssize_t n_leaves = 0, n_topo = 0;
    for (Py_ssize_t x = 0; x < nn; x++) {
        n_leaves += last[x] < 0;
    }
    o_leaves = PyList_New(n_leaves);
    o_topo = PyList_New(size); /* every node once (a leaf first, else after its last arc) */
    if (o_leaves == NULL || o_topo == NULL) {
        goto fail;
    }
    n_leaves = 0;
    for (Py_ssize_t x = 0; x < nn; x++) {
        if (last[x] < 0) {
            SET(o_leaves, n_leaves, PyLong_FromSsize_t(x));
            n_leaves++;
            SET(o_topo, n_topo, PyLong_FromSsize_t(x));
            n_topo++;
        }
        else if (!consumed[x] && x != root) {
            APPEND(o_dead, PyLong_FromSsize_t(x)); /* produced, used by none: a dead end */
        }
    }
    for (Py_ssize_t a = nn; a < size; a++) {
        SET(o_topo, n_topo, PyLong_FromSsize_t(a));
        n_topo++;
        if (last[parent[a]] == a) {
            SET(o_topo, n_topo, PyLong_FromSsize_t(parent[a]));
            n_topo++;
        }
    }
    result = Py_BuildValue("(NNnNNNNNNnNNNlNN)", o_name, o_root_name, nn, o_names, o_weights,
                           o_children, o_parent, o_inc, o_lower, root, o_topo, o_leaves,
                           o_lines, rows[0].line, o_dead, o_refs);
    Py_DECREF(empty);
    Py_DECREF(zero);
    Py_DECREF(minus);
    goto done;
fail:
    Py_XDECREF(o_names);
    Py_XDECREF(o_weights);
    Py_XDECREF(o_children);
    Py_XDECREF(o_parent);
    Py_XDECREF(o_inc);
    Py_XDECREF(o_lower);
    Py_XDECREF(o_refs);
    Py_XDECREF(o_topo);
    Py_XDECREF(o_leaves);
    Py_XDECREF(o_lines);
    Py_XDECREF(o_dead);
    Py_XDECREF(empty);
    Py_XDECREF(o_name);
    Py_XDECREF(o_root_name);
    Py_XDECREF(zero);
    Py_XDECREF(minus);
    result = NULL;
done:
    PyMem_Free(names);
    PyMem_Free(lines);
    PyMem_Free(parent);
    PyMem_Free(child_off);
    PyMem_Free(child_ids);
    PyMem_Free(arc_tok);
    PyMem_Free(last);
    PyMem_Free(consumed);
    PyMem_Free(inc_count);
    PyMem_Free(inc_off);
    PyMem_Free(inc_ids);
    PyMem_Free(nodes_tb.slot);
    PyMem_Free(arcs_tb.slot);
    return result;
#undef SET
#undef APPEND
}

static PyObject *
parse(PyObject *module, PyObject *arg)
{
    (void)module;
    if (!PyBytes_Check(arg)) {
        PyErr_SetString(PyExc_TypeError, "parse() needs bytes");
        return NULL;
    }
    const char *s = PyBytes_AS_STRING(arg);
    Py_ssize_t n = PyBytes_GET_SIZE(arg);
    Tok *toks;
    Row *rows;
    Py_ssize_t ntok, nrows;
    if (!tokenize(s, n, &toks, &ntok, &rows, &nrows)) {
        if (PyErr_Occurred()) {
            return NULL;
        }
        Py_RETURN_NONE;
    }
    PyObject *r = build(toks, rows, nrows);
    PyMem_Free(toks);
    PyMem_Free(rows);
    if (r == Py_None) {
        Py_RETURN_NONE;
    }
    return r;
}

/* The bytes of a file; NULL without an exception when it cannot be read (the Python reader
 * then reads it and says why), with a TypeError when ``path`` is no path at all. */
static PyObject *
read_file(PyObject *path)
{
    PyObject *encoded = NULL;
    if (!PyUnicode_FSConverter(path, &encoded)) {
        if (!PyErr_ExceptionMatches(PyExc_TypeError)) {
            PyErr_Clear(); /* a path os.open() would refuse too (a NUL in it): Python's */
        }
        return NULL;
    }
    int fd;
    do {
        fd = open(PyBytes_AS_STRING(encoded), O_RDONLY | O_CLOEXEC);
    } while (fd < 0 && errno == EINTR);
    Py_DECREF(encoded);
    if (fd < 0) {
        return NULL;
    }
    Py_ssize_t cap = 1 << 16, len = 0;
    PyObject *buf = PyBytes_FromStringAndSize(NULL, cap);
    while (buf != NULL) {
        if (len == cap) {
            cap *= 2;
            if (_PyBytes_Resize(&buf, cap) < 0) {
                break; /* (buf is NULL now) */
            }
        }
        ssize_t got = read(fd, PyBytes_AS_STRING(buf) + len, (size_t)(cap - len));
        if (got < 0 && errno == EINTR) {
            continue;
        }
        if (got < 0) {
            Py_CLEAR(buf);
            break;
        }
        if (got == 0) {
            _PyBytes_Resize(&buf, len);
            break;
        }
        len += got;
    }
    close(fd);
    PyErr_Clear();
    return buf;
}

static PyObject *
parse_file(PyObject *module, PyObject *path)
{
    PyObject *data = read_file(path);
    if (data == NULL) {
        if (PyErr_Occurred()) {
            return NULL;
        }
        Py_RETURN_NONE;
    }
    PyObject *r = parse(module, data);
    if (r != Py_None) {
        Py_DECREF(data);
        return r; /* (or NULL: an error) */
    }
    Py_DECREF(r);
    return data; /* declined: the Python reader takes the bytes from here, no second read */
}

static PyMethodDef methods[] = {
    {"parse_file", parse_file, METH_O,
     "parse_file(path) -> what parse() gives for the file's bytes, or the bytes when parse() "
     "declines them; None when the file cannot be read."},
    {"parse", parse, METH_O,
     "parse(data) -> (name, root name, number of nodes, names, weights, children, parent, "
     "incoming, lower, root id, topological order, leaves, lines, header line, dead ends, "
     "references) for a file the pure-Python fast path accepts and this reader can read, "
     "else None."},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module_def = {
    PyModuleDef_HEAD_INIT, "_andor_fast",
    "The common case of the ANDOR text reader, compiled (see andor_text).", -1, methods,
    NULL, NULL, NULL, NULL,
};

PyMODINIT_FUNC
PyInit__andor_fast(void)
{
    for (int v = 0; v < N_SMALL_FLOATS; v++) {
        if (small_floats[v] == NULL && (small_floats[v] = PyFloat_FromDouble(v)) == NULL) {
            return NULL;
        }
    }
    return PyModule_Create(&module_def);
}
