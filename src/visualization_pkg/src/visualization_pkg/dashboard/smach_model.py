"""The SMACH tree as seen through the introspection topics, and a layered layout of it.

No rospy, no Qt: the panel feeds message fields in and draws the layout it gets back.

Introspection conventions (smach_ros, and control_pkg's fallback server): one structure and one
status message per container; a container's path is its parent's path + '/' + its label
(the root e.g. '/SM_ROOT'); an idle StateMachine reports active_states ['None'].
"""

_IDLE = ('None', '')


def join(path, label):
    return path.rstrip('/') + '/' + label


def parent_of(path):
    head, _, _ = path.rstrip('/').rpartition('/')
    return head


class Container(object):
    """What is known about one container: structure and latest status."""

    def __init__(self, path):
        self.path = path
        self.children = []
        self.edges = []                 # (outcome, from_label, to_label)
        self.outcomes = []
        self.initial_states = []
        self.active_states = []
        self.local_data = ''
        self.info = ''
        self.has_structure = False
        self.has_status = False

    @property
    def label(self):
        return self.path.rstrip('/').rpartition('/')[2] or self.path


class SmachModel(object):
    """Containers by path; which states are active; view roots for the panel."""

    def __init__(self):
        self.containers = {}

    def _get(self, path):
        c = self.containers.get(path)
        if c is None:
            c = self.containers[path] = Container(path)
        return c

    def update_structure(self, path, children, internal_outcomes, outcomes_from, outcomes_to,
                         container_outcomes):
        """Store a structure message; True when it changed what is drawn."""
        c = self._get(path)
        edges = list(zip(internal_outcomes, outcomes_from, outcomes_to))
        new = (list(children), edges, list(container_outcomes))
        changed = not c.has_structure or (c.children, c.edges, c.outcomes) != new
        c.children, c.edges, c.outcomes = new
        c.has_structure = True
        return changed

    def update_status(self, path, initial_states, active_states, local_data, info=''):
        """Store a status message; True when the active or initial states changed."""
        c = self._get(path)
        new = (list(initial_states), list(active_states))
        changed = not c.has_status or (c.initial_states, c.active_states) != new
        c.initial_states, c.active_states = new
        c.local_data = local_data
        c.info = info
        c.has_status = True
        return changed

    def clear(self):
        self.containers.clear()

    # --- queries ------------------------------------------------------------------------------
    def is_container(self, path):
        return path in self.containers

    def roots(self):
        """Containers whose parent is not a known container (normally just '/SM_ROOT')."""
        return sorted(p for p in self.containers if parent_of(p) not in self.containers)

    def container_paths(self):
        return sorted(self.containers)

    def active_labels(self, path):
        c = self.containers.get(path)
        if c is None:
            return []
        return [s for s in c.active_states if s not in _IDLE]

    def active_paths(self):
        """Full paths of every active state (containers included), following only active parents.

        A nested container's status counts only while its parent lists it as active, so a stale
        status of a finished container is ignored.
        """
        out = set()
        stack = list(self.roots())
        while stack:
            path = stack.pop()
            for label in self.active_labels(path):
                child = join(path, label)
                out.add(child)
                if child in self.containers:
                    stack.append(child)
        return out

    def active_leaves(self):
        """Active states that are not containers, sorted (e.g. '/SM_ROOT/RUN/MISSION/DO_MOVEBASE')."""
        return sorted(p for p in self.active_paths() if p not in self.containers)

    def deepest_active_container(self):
        """The deepest container that has an active state, or the first root."""
        best = None
        for path in self.active_paths() | set(self.roots()):
            if path in self.containers and self.active_labels(path):
                if best is None or path.count('/') > best.count('/'):
                    best = path
        return best or (self.roots()[0] if self.roots() else None)

    def follow_root(self, depth):
        """View root that shows the deepest active container with `depth` levels expanded.

        With depth d the view root is d-1 levels above the deepest active container (never above
        a root), so the active leaf is always drawn.
        """
        path = self.deepest_active_container()
        if path is None:
            return None
        for _ in range(max(0, depth - 1)):
            parent = parent_of(path)
            if parent not in self.containers:
                break
            path = parent
        return path

    def owner_of(self, path):
        """The container whose userdata describes `path`: itself for a container, else its parent."""
        if path in self.containers:
            return path
        parent = parent_of(path)
        return parent if parent in self.containers else None


# --- layout ---------------------------------------------------------------------------------------
class Node(object):
    """One box of the layout. kind: 'state', 'container' (expanded), 'collapsed' or 'outcome'."""

    def __init__(self, key, label, kind, w, h):
        self.key = key          # full path; outcomes: container path + '/:' + outcome
        self.label = label
        self.kind = kind
        self.x = 0.0
        self.y = 0.0
        self.w = float(w)
        self.h = float(h)
        self.layer = 0
        self.block = None       # Block of an expanded container

    def move(self, dx, dy):
        self.x += dx
        self.y += dy
        if self.block is not None:
            self.block.move(dx, dy)


class Block(object):
    """The layout of one container's inside: nodes and edges in absolute coordinates."""

    def __init__(self, path):
        self.path = path
        self.nodes = []
        self.edges = []         # (from_key, to_key, outcome_label, is_back_edge)
        self.w = 0.0
        self.h = 0.0

    def move(self, dx, dy):
        for n in self.nodes:
            n.move(dx, dy)

    def walk(self):
        """Every node of this block and of the blocks nested in it."""
        for n in self.nodes:
            yield n
            if n.block is not None:
                for m in n.block.walk():
                    yield m

    def all_edges(self):
        for e in self.edges:
            yield e
        for n in self.nodes:
            if n.block is not None:
                for e in n.block.all_edges():
                    yield e


def outcome_key(container_path, outcome):
    return container_path + '/:' + outcome


class Style(object):
    """Spacing of the layout, in scene units (pixels at zoom 1)."""
    node_h = 26.0
    pad_x = 14.0
    min_w = 70.0
    gap_x = 22.0
    gap_y = 34.0
    margin = 12.0
    header = 22.0


def layered_order(children, edges, initial):
    """Assign layers to `children` (labels): longest path over forward edges from the initial state.

    `edges`: (outcome, from_label, to_label). Back edges (closing a cycle in a depth-first walk
    from the initial state) are ignored for layering. Returns ({label: layer}, set of back edges
    as (from, to)).
    """
    succ = dict((c, []) for c in children)
    for _, a, b in edges:
        if a in succ and b in succ and b not in succ[a]:
            succ[a].append(b)
    starts = [s for s in initial if s in succ] or list(children[:1])
    order = starts + [c for c in children if c not in starts]
    back = set()
    state = {}                  # label -> 1 on stack, 2 done
    for root in order:
        if root in state:
            continue
        stack = [(root, iter(succ[root]))]
        state[root] = 1
        while stack:
            node, it = stack[-1]
            nxt = next(it, None)
            if nxt is None:
                state[node] = 2
                stack.pop()
            elif state.get(nxt) == 1:
                back.add((node, nxt))
            elif nxt not in state:
                state[nxt] = 1
                stack.append((nxt, iter(succ[nxt])))
    layer = dict((c, 0) for c in children)
    # longest path: relax forward edges |V| times (graphs are small)
    for _ in range(len(children)):
        changed = False
        for a in children:
            for b in succ[a]:
                if (a, b) not in back and layer[b] < layer[a] + 1:
                    layer[b] = layer[a] + 1
                    changed = True
        if not changed:
            break
    return layer, back


def layout(model, root_path, depth, measure, style=Style):
    """Layered layout of the container `root_path` with `depth` levels of containers expanded.

    `measure(text) -> (width, height)` gives the text size in scene units. Returns a Block with
    its origin at (0, 0), or None when the container is unknown.
    """
    if root_path not in model.containers:
        return None
    return _layout_container(model, root_path, max(1, depth), measure, style)


def _leaf_size(label, measure, style):
    w, _ = measure(label)
    return max(style.min_w, w + 2 * style.pad_x), style.node_h


def _layout_container(model, path, depth, measure, style):
    c = model.containers[path]
    block = Block(path)
    nodes = {}
    for label in c.children:
        key = join(path, label)
        if key in model.containers and depth > 1:
            inner = _layout_container(model, key, depth - 1, measure, style)
            tw, _ = measure(label)
            n = Node(key, label, 'container', max(inner.w, tw + 2 * style.pad_x),
                     inner.h + style.header)
            n.block = inner
            # centre the inner block under the header
            inner.move((n.w - inner.w) / 2.0, style.header)
        else:
            kind = 'collapsed' if key in model.containers else 'state'
            w, h = _leaf_size(label, measure, style)
            n = Node(key, label, kind, w, h)
        nodes[label] = n
    layer, back = layered_order(c.children, c.edges, c.initial_states)
    last = max(layer.values()) + 1 if layer else 0
    outcome_nodes = {}
    for outcome in c.outcomes:
        w, h = _leaf_size(outcome, measure, style)
        n = Node(outcome_key(path, outcome), outcome, 'outcome', w, h)
        n.layer = last
        outcome_nodes[outcome] = n
    for label, n in nodes.items():
        n.layer = layer.get(label, 0)

    # rows, ordered by first appearance, then one barycentre sweep against the row above
    rows = {}
    for label in c.children:
        rows.setdefault(nodes[label].layer, []).append(nodes[label])
    if outcome_nodes:
        rows.setdefault(last, []).extend(outcome_nodes[o] for o in c.outcomes)
    key_of = dict((label, n.key) for label, n in nodes.items())
    key_of.update((o, n.key) for o, n in outcome_nodes.items())
    preds = {}
    for _, a, b in c.edges:
        if a in key_of and b in key_of and (a, b) not in back:
            preds.setdefault(key_of[b], []).append(key_of[a])
    index = {}
    for r in sorted(rows):
        if r > 0:
            keys = []
            for i, n in enumerate(rows[r]):
                ps = [index[p] for p in preds.get(n.key, []) if p in index]
                keys.append((sum(ps) / float(len(ps)) if ps else float(i), i))
            rows[r] = [n for _, n in sorted(zip(keys, rows[r]), key=lambda kn: kn[0])]
        for i, n in enumerate(rows[r]):
            index[n.key] = i + 0.0

    # place rows: centred horizontally, stacked top to bottom
    widths = dict((r, sum(n.w for n in row) + style.gap_x * (len(row) - 1)) for r, row in rows.items())
    inner_w = max(widths.values()) if widths else style.min_w
    y = style.margin
    for r in sorted(rows):
        row = rows[r]
        x = style.margin + (inner_w - widths[r]) / 2.0
        row_h = max(n.h for n in row)
        for n in row:
            n.move(x - n.x, y + (row_h - n.h) / 2.0 - n.y)
            x += n.w + style.gap_x
        y += row_h + style.gap_y
    block.w = inner_w + 2 * style.margin
    block.h = y - style.gap_y + style.margin if rows else 2 * style.margin
    block.nodes = [n for r in sorted(rows) for n in rows[r]]
    for outcome, a, b in c.edges:
        if a in key_of and b in key_of:
            block.edges.append((key_of[a], key_of[b], outcome, (a, b) in back or a == b))
    return block
