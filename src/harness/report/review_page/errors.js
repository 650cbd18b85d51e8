// Shows script errors on the page (the browser test looks for them).
window.addEventListener('error',function(e){var p=document.getElementById('js-errors');p.hidden=false;p.textContent+=(e.message||'error')+' ('+(e.lineno||0)+':'+(e.colno||0)+')\n';});
