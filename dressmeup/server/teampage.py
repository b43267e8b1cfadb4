"""The team page: a form for the token, the team's submissions fetched with it (the token
stays in the page; every value is put in as text, never as markup)."""

TEAM_PAGE = """<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>Your submissions</title>
<style>
  body { font-family: -apple-system, "Segoe UI", Roboto, Helvetica, Arial, sans-serif;
         margin: 2rem auto; max-width: 70rem; padding: 0 1rem; color: #1f2430; }
  table { border-collapse: collapse; width: 100%; margin-top: 1rem; }
  th, td { border-bottom: 1px solid #e3e6ee; padding: .35rem .6rem; text-align: left; }
  .failed { color: #b3261e; } .scored { color: #1b7f3b; }
  #error { color: #b3261e; }
</style>
</head>
<body>
<h1>Your submissions</h1>
<form id="login">
  <label>API token <input id="token" type="password" autocomplete="off" size="50"></label>
  <button type="submit">Show</button>
</form>
<p id="error"></p>
<table id="subs" hidden>
<thead><tr><th>id</th><th>edition</th><th>method</th><th>status</th><th>published as</th>
<th>submitted</th></tr></thead>
<tbody></tbody>
</table>
<p><a href="/leaderboard/">Public leaderboards</a></p>
<script>
document.getElementById("login").addEventListener("submit", async function (ev) {
  ev.preventDefault();
  var token = document.getElementById("token").value.trim();
  var err = document.getElementById("error");
  err.textContent = "";
  var res = await fetch("/api/submissions", {headers: {"Authorization": "Bearer " + token}});
  if (!res.ok) { err.textContent = "token refused (" + res.status + ")"; return; }
  var rows = await res.json();
  var body = document.querySelector("#subs tbody");
  body.replaceChildren();
  rows.forEach(function (r) {
    var tr = document.createElement("tr");
    [r.id, r.edition, r.method, r.status + (r.error ? ": " + r.error : ""),
     r.published ? r.public_method : "", r.created_at].forEach(function (v, i) {
      var td = document.createElement("td");
      td.textContent = v;
      if (i === 3) { td.className = r.status; }
      tr.appendChild(td);
    });
    body.appendChild(tr);
  });
  document.getElementById("subs").hidden = false;
});
</script>
</body>
</html>
"""
