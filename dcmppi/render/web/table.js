// Sortable tables: a click on a heading sorts the rows by that column (numbers by their
// leading value, '-' last), a second click reverses. dcmppi's own code, no library.
document.querySelectorAll("table.sortable").forEach((table) => {
  const heads = table.tHead.rows[0].cells;
  Array.from(heads).forEach((th, col) => {
    th.addEventListener("click", () => {
      const body = table.tBodies[0];
      const rows = Array.from(body.rows);
      const key = (row) => row.cells[col].textContent.trim();
      const numeric = rows.every((r) => ["", "-"].includes(key(r)) || !isNaN(parseFloat(key(r))));
      const up = !th.classList.contains("asc");
      const value = (r) => {
        const text = key(r);
        if (!numeric) return text;
        const x = parseFloat(text);
        return isNaN(x) ? null : x;
      };
      rows.sort((a, b) => {
        const x = value(a), y = value(b);
        if (x === y) return 0;
        if (x === null) return 1;
        if (y === null) return -1;
        const order = numeric ? x - y : String(x).localeCompare(String(y));
        return up ? order : -order;
      });
      Array.from(heads).forEach((h) => h.classList.remove("asc", "desc"));
      th.classList.add(up ? "asc" : "desc");
      rows.forEach((r) => body.appendChild(r));
    });
  });
});
